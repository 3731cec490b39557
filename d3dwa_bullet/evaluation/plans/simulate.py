"""Sequential readings simulated: how often a rule reads what, when the truth is known.

:func:`simulate` draws ``replicates`` cells of n layouts whose per-layout differences are
N(true, sd), reads each at k equally spaced looks by the plan's rule (``looks.decisions`` on
``looks.prefix_estimates``, Lan-DeMets O'Brien-Fleming boundaries for the t,
``student.rule_boundaries``, at alpha / 2 each way and alpha for TOST) and returns each cell's
reading and the look it came at. Vectorised over the replicates: 20,000 cells of 200 layouts
take about a second, plus a few seconds for a new set of looks' boundaries (then cached). Used
by the simulation tests and ``tools/experiments/sequential_check.py``
(docs/design/sequential-plans.md).
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.evaluation.plans.looks import decisions, first_reading, prefix_estimates
from d3dwa_bullet.evaluation.plans.student import rule_boundaries


def simulate(
    true: float,
    n: int,
    margin: float,
    k: int,
    replicates: int,
    seed: int,
    alpha: float = 0.05,
    sd: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(reading code (replicates,), look index (replicates,)) of ``replicates`` simulated cells
    (codes of ``looks``: A_BETTER, B_BETTER, EQUIVALENT, INCONCLUSIVE); the looks at
    round(j n / k) layouts, j = 1..k."""
    d = np.random.default_rng(seed).normal(true, sd, size=(replicates, n))
    looks = np.round(np.arange(1, k + 1) / k * n).astype(int)
    diff, se, df = prefix_estimates(d, looks)
    bound_d, bound_t = rule_boundaries(looks, n, alpha)
    codes = decisions(diff, se, df, margin, bound_d, bound_t)
    return first_reading(codes)
