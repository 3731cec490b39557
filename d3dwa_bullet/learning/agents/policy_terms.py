"""The terms a trained policy is driven on, as its files record them: its decision period
and the recovery layer it trained inside.

A policy trained with ``decision_steps`` k > 1 (beyond the paper, docs/design.md#decision-period)
chose once per k control steps, so whatever drives it must hold each action as long
(``planning.controller.Controller.hold``); one trained inside a recovery layer (docs/design.md#recovery)
met the states that layer leaves it, so a run without it is not the run it learned for.
Both are read from a checkpoint's meta.json (``metadata.decision_steps``,
``metadata.recovery``) and from an exported ONNX file's metadata (``onnx_policy``), and
checked the same way here, so a torch checkpoint and its export are driven alike. An
absent value is the paper's: period 1, recovery ``none``.

Pure: no torch, no onnxruntime (the ONNX runner imports this on a robot without torch).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.limits import MAX_DECISION_STEPS as DECISION_LIMIT
from d3dwa_bullet.params import RECOVERY_KINDS

MAX_DECISION_STEPS = int(DECISION_LIMIT.value)
"""Longest decision period, control steps (its one home: ``limits.MAX_DECISION_STEPS``)."""
DEFAULT_DECISION_STEPS = 1
"""The paper's agent: one decision every control step."""
DEFAULT_RECOVERY = RECOVERY_KINDS[0]
"""No recovery layer (the paper's stack)."""
_SHOWN = 60  # characters of a bad value kept in a message


def decision_period(value: object, where: str) -> int:
    """A recorded decision period as an int in [1, MAX_DECISION_STEPS]: an int, or its
    decimal digits as an ONNX metadata string holds it. CheckpointError (one line,
    ``where`` first: the file and the key) for anything else."""
    number = None
    if isinstance(value, int) and not isinstance(value, bool):
        number = value
    elif isinstance(value, str) and value.isascii() and value.isdigit() and len(value) <= 3:
        number = int(value)  # 3 digits reach MAX_DECISION_STEPS; int() of more may raise
    if number is not None and 1 <= number <= MAX_DECISION_STEPS:
        return number
    raise CheckpointError(
        f"{where} is {_shown(value)}, expected a whole number in [1, {MAX_DECISION_STEPS}] "
        "(control steps each chosen action is held)"
    )


def trained_recovery(value: object, where: str) -> str:
    """A recorded recovery layer as one of RECOVERY_KINDS; CheckpointError (one line,
    ``where`` first) for anything else."""
    if isinstance(value, str) and value in RECOVERY_KINDS:
        return value
    raise CheckpointError(
        f"{where} is {_shown(value)}, expected one of {', '.join(RECOVERY_KINDS)} "
        "(the recovery layer the policy trained inside)"
    )


def checkpoint_terms(meta: Mapping[str, Any], where: str) -> tuple[int, str]:
    """(decision period, recovery) of a checkpoint's meta.json ``meta`` (its ``metadata``
    block; absent values are the paper's). where: the meta.json file, for messages."""
    extra = meta.get("metadata")
    extra = extra if isinstance(extra, Mapping) else {}
    return (
        decision_period(
            extra.get("decision_steps", DEFAULT_DECISION_STEPS),
            f"{where}: metadata.decision_steps",
        ),
        trained_recovery(extra.get("recovery", DEFAULT_RECOVERY), f"{where}: metadata.recovery"),
    )


def _shown(value: object) -> str:
    """repr of a value, cut to one short line (a file could hold a long string)."""
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than Python will print
        return "an integer too long to show"
    return text if len(text) <= _SHOWN else f"{text[: _SHOWN - 3]}..."
