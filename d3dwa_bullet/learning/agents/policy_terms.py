"""The terms a trained policy is driven on, as its files record them: its decision period,
the recovery layer it trained inside and the scan filter it trained behind.

A policy trained with ``decision_steps`` k > 1 (beyond the paper, docs/design/agent.md#decision-period)
chose once per k control steps, so whatever drives it must hold each action as long
(``planning.controller.Controller.hold``); one trained inside a recovery layer (docs/design/recovery.md#recovery)
met the states that layer leaves it, so a run without it is not the run it learned for.
One trained behind a scan filter (docs/design/scan-filter.md#scan-filter) learned on filtered scans, so
it is driven only behind the same filter (``planning.scan_filter.check_driven_filter``).
All are read from a checkpoint's meta.json (``metadata.decision_steps``,
``metadata.recovery``, ``metadata.scan_filter``) and from an exported ONNX file's metadata
(``onnx_policy``), and checked the same way here, so a torch checkpoint and its export are
driven alike. An absent value is the paper's: period 1, recovery ``none``, filter ``none``.

Pure: no torch, no onnxruntime (the ONNX runner imports this on a robot without torch).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.limits import MAX_DECISION_STEPS, is_decision_period
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.params import RECOVERY_KINDS
from d3dwa_bullet.planning.scan_filter import SCAN_FILTERS

DEFAULT_DECISION_STEPS = 1
"""The paper's agent: one decision every control step."""
DEFAULT_RECOVERY = RECOVERY_KINDS[0]
"""No recovery layer (the paper's stack)."""
DEFAULT_SCAN_FILTER = "none"
"""No scan filter (the paper's stack)."""
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
    if number is not None and is_decision_period(number):
        return number
    raise CheckpointError(
        f"{where} is {shown_value(value)}, expected a whole number in [1, {MAX_DECISION_STEPS.value}] "
        "(control steps each chosen action is held)"
    )


def trained_recovery(value: object, where: str) -> str:
    """A recorded recovery layer as one of RECOVERY_KINDS; CheckpointError (one line,
    ``where`` first) for anything else."""
    if isinstance(value, str) and value in RECOVERY_KINDS:
        return value
    raise CheckpointError(
        f"{where} is {shown_value(value)}, expected one of {', '.join(RECOVERY_KINDS)} "
        "(the recovery layer the policy trained inside)"
    )


def trained_scan_filter(value: object, where: str) -> str:
    """A recorded scan filter as one of SCAN_FILTERS; CheckpointError (one line, ``where``
    first) for anything else."""
    if isinstance(value, str) and value in SCAN_FILTERS:
        return value
    raise CheckpointError(
        f"{where} is {shown_value(value)}, expected one of {', '.join(SCAN_FILTERS)} "
        "(the scan filter the policy trained behind)"
    )


def checkpoint_terms(meta: Mapping[str, Any], where: str) -> tuple[int, str, str]:
    """(decision period, recovery, scan filter) of a checkpoint's meta.json ``meta`` (its
    ``metadata`` block; absent values are the paper's). where: the meta.json file, for messages. A
    ``metadata`` that is not a mapping is refused: read as empty, it would drive a held
    policy every step without a word."""
    extra = meta.get("metadata", {})
    if not isinstance(extra, Mapping):
        raise CheckpointError(
            f"{where}: metadata is {shown_value(extra)}, expected a mapping (it records the "
            "policy's decision period, recovery layer and scan filter)"
        )
    return (
        decision_period(
            extra.get("decision_steps", DEFAULT_DECISION_STEPS),
            f"{where}: metadata.decision_steps",
        ),
        trained_recovery(extra.get("recovery", DEFAULT_RECOVERY), f"{where}: metadata.recovery"),
        trained_scan_filter(
            extra.get("scan_filter", DEFAULT_SCAN_FILTER), f"{where}: metadata.scan_filter"
        ),
    )


def shown_value(value: object) -> str:
    """repr of a value, cut to one short line for a message naming a bad value read from a
    policy's files (a file could hold a long string, or an integer too long to print)."""
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than Python will print
        return "an integer too long to show"
    return text if len(text) <= _SHOWN else f"{text[: _SHOWN - 3]}..."


TERMS = ("decision_steps", "recovery", "observation", "scan_filter")
"""What a checkpoint's meta.json (``metadata``) and its run's config.json both record of the
terms the policy is driven on; they must agree."""


def read_meta(meta_file: Path) -> Mapping[str, Any]:
    """A checkpoint's meta.json as a mapping; CheckpointError, one line naming the file, when it
    cannot be read or is not a JSON object."""
    meta = load_json(meta_file, CheckpointError, "checkpoint meta.json")
    if not isinstance(meta, Mapping):
        raise CheckpointError(f"{meta_file}: expected a JSON object, got {type(meta).__name__}")
    return meta


def folder_terms(folder: str | os.PathLike[str]) -> dict[str, object]:
    """The terms a checkpoint folder's policy is driven on, {decision_steps, recovery,
    observation (None when unrecorded), scan_filter}, read from its meta.json and checked against its
    config.json when it has one: CheckpointError, one line naming both files, the term and
    both values, when they disagree or either is malformed."""
    root = Path(folder)
    meta_file, config_file = root / "meta.json", root / "config.json"
    meta = read_meta(meta_file)
    period, recovery, behind = checkpoint_terms(meta, str(meta_file))
    extra = meta.get("metadata", {})
    terms: dict[str, object] = {
        "decision_steps": period,
        "recovery": recovery,
        "observation": extra.get("observation"),
        "scan_filter": behind,
    }
    if not config_file.is_file():
        return terms
    config = load_json(config_file, CheckpointError, "training config.json")
    if not isinstance(config, Mapping):
        raise CheckpointError(f"{config_file}: expected a JSON object, got {type(config).__name__}")
    recorded = {
        "decision_steps": decision_period(
            config.get("decision_steps", DEFAULT_DECISION_STEPS), f"{config_file}: decision_steps"
        ),
        "recovery": trained_recovery(
            config.get("recovery", DEFAULT_RECOVERY), f"{config_file}: recovery"
        ),
        "observation": config.get("observation"),
        "scan_filter": trained_scan_filter(
            config.get("scan_filter", DEFAULT_SCAN_FILTER), f"{config_file}: scan_filter"
        ),
    }
    for name in TERMS:
        mine, theirs = terms[name], recorded[name]
        if name == "observation" and (mine is None or theirs is None):
            terms[name] = mine if theirs is None else theirs
            continue
        if mine != theirs:
            raise CheckpointError(
                f"{meta_file}: metadata.{name} is {shown_value(mine)} but {config_file} says "
                f"{shown_value(theirs)}; a policy's files must agree on the terms it is driven on"
            )
    return terms
