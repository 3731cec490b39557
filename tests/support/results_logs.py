"""A results directory made by hand (`d3dwa eval`'s, or `d3dwa sweep`'s with its layout
columns): rows in results.csv, each with its per-step log under logs/, as the tools that read
episode logs (jobs.row_log) expect."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.evaluation.jobs import log_name
from d3dwa_bullet.evaluation.results import CSV_FIELDS, appending_rows, row_key

ROW_DEFAULTS = dict(seed=0, outcome="goal", time_s=1.0, tl_m=0.0, pd_rad=0.0,
                    min_clearance_m=0.1, steps=10, score=1.0, score_barn=0.2,
                    reference_length_m=0.4)  # fmt: skip
"""The fields a test leaves out (the score of a goal in 1 s on a 0.4 m route at 0.4 m/s)."""
SWEEP_DEFAULTS = dict(axis="profile", level="", layout="generated")
"""... and the sweep's own columns."""


def write_results(
    out: Path, episodes: Iterable[tuple[Mapping[str, Any], Mapping[str, Any]]], sweep: bool = True
) -> Path:
    """out, holding one results row per (row, log arrays) pair (the row over the defaults)
    and its log (np.savez of the arrays); a sweep's columns unless sweep is False."""
    (out / "logs").mkdir(parents=True)
    fields, defaults = CSV_FIELDS, ROW_DEFAULTS
    if sweep:
        fields, defaults = CSV_FIELDS + tuple(SWEEP_DEFAULTS), ROW_DEFAULTS | SWEEP_DEFAULTS
    with appending_rows(out, fields) as append:
        for given, arrays in episodes:
            row = defaults | dict(given)
            append(row)
            seed = row["policy_seed"]
            key = row_key(row | {"policy_seed": None if seed == "" else seed})
            np.savez(out / "logs" / log_name(key), **arrays)
    return out
