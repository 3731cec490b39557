"""Equivalence margins: how close two methods must be to read as equivalent, per metric.

A margin is stated before a run (docs/design/readings.md#readings) in its metric's own units: success
as a fraction (the command line takes points), the scores in [0, 1]. The defaults mean
something to a user: 3 success points; 0.03 of the robot-scaled score (a few per cent of a
typical success's score); 0.01 of BARN's official score (about 6 % of the challenge's DWA
example, 0.169). No SciPy here, so the command line can build its options without loading it.
"""

from __future__ import annotations

import math

from d3dwa_bullet.errors import ConfigError

MARGINS = {"success": 0.03, "score": 0.03, "score_barn": 0.01}
"""Default margins, in each metric's units (success as a fraction: 3 points)."""
MARGIN_OPTIONS = {"success": "--margin-success", "score": "--margin-score",
                  "score_barn": "--margin-barn"}  # fmt: skip
"""The option that sets each metric's margin (--margin-success in points)."""
METRIC_NAMES = {"success": "success rate", "score": "score", "score_barn": "BARN official score"}


def option_value(metric: str, margin: float) -> float:
    """A margin as its option takes it: success in points, a score as is."""
    return 100 * margin if metric == "success" else margin


def check_margin(value: float, metric: str) -> float:
    """A margin given to metric's option (success in points), checked: a finite number > 0 and
    at most the metric's whole range; returned in the metric's units. ConfigError naming the
    option and the value otherwise."""
    top = option_value(metric, 1.0)
    if not (math.isfinite(value) and 0 < value <= top):
        raise ConfigError(
            f"{MARGIN_OPTIONS[metric]} must be a positive finite number up to {top:g}, "
            f"got {value:g}"
        )
    return value / 100 if metric == "success" else float(value)


def margin_text(metric: str, margin: float) -> str:
    """The margin as a reader takes it: success in points ('±3 points'), a score as is."""
    return f"±{100 * margin:g} points" if metric == "success" else f"±{margin:g}"
