"""How each typed column of results.csv is read, the one track a directory holds, and the
columns a run adds beside CSV_FIELDS (recovery, backend, global plan, method source).

A NaN or inf where a table averages, or an outcome no table counts, is refused, not counted
(``TYPED_COLUMNS``); so is a hand-edited ``recovery`` column that mixes tracks or names no
recovery layer (``check_one_track``): a results directory is one track (docs/design/recovery.md#recovery),
and pooling two would report a table neither track ran.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.episode_metrics import OUTCOMES
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.limits import MAX_NOTE_VALUE_CHARS, cut_text
from d3dwa_bullet.params import RECOVERY_KINDS


def _checked(parse: Callable[[str], Any], ok: Callable[[Any], bool]) -> Callable[[str], Any]:
    """parse, refusing (ValueError) a value that ok says no to."""

    def read(text: str) -> Any:
        if not ok(value := parse(text)):
            raise ValueError(text)
        return value

    return read


_COUNT = (_checked(int, lambda v: v >= 0), "a whole number >= 0")
TYPED_COLUMNS: dict[str, tuple[Callable[[str], Any], str]] = {
    "seed": _COUNT,
    "policy_seed": (
        _checked(lambda t: None if t == "" else int(t), lambda v: v is None or v >= 0),
        "empty or a whole number >= 0",
    ),
    "outcome": (_checked(str, lambda v: v in OUTCOMES), f"one of {', '.join(OUTCOMES)}"),
    **dict.fromkeys(
        ("time_s", "tl_m", "pd_rad"),
        (_checked(float, lambda v: math.isfinite(v) and v >= 0), "a finite number >= 0"),
    ),
    "min_clearance_m": (
        _checked(float, lambda v: not math.isnan(v) and v > -math.inf),
        "a number, or inf for a world without obstacles",
    ),
    "steps": _COUNT,
    **dict.fromkeys(
        ("score", "score_barn"),
        (_checked(float, lambda v: 0 <= v <= 1), "a number from 0 to 1"),
    ),
    "reference_length_m": (
        _checked(float, lambda v: math.isfinite(v) and v > 0),
        "a finite number > 0",
    ),
}
"""How read_results reads each typed column, and what the message says it must be: a NaN
or inf where a table averages, or an outcome no table counts, is refused, not counted. The
score columns are absent from a directory made before the score; its rows read them as None."""


def check_one_track(path: Path, rows: Sequence[Mapping[str, Any]], column: str) -> None:
    """ResultsError (one line: file, line, value) unless every row's ``column`` names one
    and the same recovery layer of RECOVERY_KINDS (rows without it read as "none")."""
    first = None
    for line, row in enumerate(rows, start=2):
        value = row[column]
        shown = cut_text(repr(value), MAX_NOTE_VALUE_CHARS)
        if value not in RECOVERY_KINDS:
            raise ResultsError(
                f"{path}: line {line}: column {column!r} is {shown}, not one of "
                f"{', '.join(RECOVERY_KINDS)}"
            )
        if first is None:
            first = (line, value)
        elif value != first[1]:
            raise ResultsError(
                f"{path}: line {line}: column {column!r} is {shown} but line {first[0]} is "
                f"{first[1]!r}; one results directory holds one track, never pooled"
            )


RECOVERY_FIELD = "recovery"
"""The column a run with a recovery layer adds (its ``--recovery`` name in every row); a
paper-track directory has no such column, so its files keep the paper track's bytes, and
its rows read as recovery "none"."""
BACKEND_FIELD = "backend"
"""The column a run on another simulator backend than PyBullet adds (its ``--backend`` name in
every row); a PyBullet directory has no such column, so its files keep their bytes."""
SOURCE_FIELD = "method_source"
"""The column a run with a method from outside the package adds: where it came from
(``module:Name (distribution version)``, ``module:Name in FILE (sha256 HEX)`` or ``FILE (sha256
HEX)`` for an ONNX file), empty for a built-in method."""


GLOBAL_PLAN_FIELD = "global_plan"
"""The column a run with a global plan adds (its ``--global-plan`` name in every row), and its
meta.json setting; absent from a run without one (docs/design/global-plan.md)."""


def with_recovery(fields: Sequence[str], recovery: str) -> tuple[str, ...]:
    """The CSV columns of a run: fields, plus RECOVERY_FIELD when a recovery layer runs."""
    return tuple(fields) if recovery == "none" else (*fields, RECOVERY_FIELD)


def with_global_plan(fields: Sequence[str], global_plan: str) -> tuple[str, ...]:
    """The CSV columns of a run: fields, plus GLOBAL_PLAN_FIELD when a global plan runs."""
    return tuple(fields) if global_plan == "none" else (*fields, GLOBAL_PLAN_FIELD)


def with_backend(fields: Sequence[str], backend: str) -> tuple[str, ...]:
    """The CSV columns of a run: fields, plus BACKEND_FIELD when it is not PyBullet."""
    return tuple(fields) if backend == "pybullet" else (*fields, BACKEND_FIELD)


def with_sources(fields: Sequence[str], external: bool) -> tuple[str, ...]:
    """The CSV columns of a run: fields, plus SOURCE_FIELD when a method from outside the
    package runs (``external``)."""
    return (*fields, SOURCE_FIELD) if external and SOURCE_FIELD not in fields else tuple(fields)
