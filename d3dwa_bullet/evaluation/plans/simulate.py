"""Sequential readings simulated: how often a rule reads what, when the truth is known.

:func:`simulate` draws ``replicates`` cells of n layouts whose per-layout differences are
N(true, sd), reads each at k equally spaced looks by the plan's rule (``looks.decisions`` on
``looks.prefix_estimates``, Lan-DeMets O'Brien-Fleming boundaries for the t,
``student.rule_boundaries``, at alpha / 2 each way and alpha for TOST) and returns each cell's
reading and the look it came at. Vectorised over the replicates: 20,000 cells of 200 layouts
take about a second, plus a few seconds for a new set of looks' boundaries (then cached). Used
by the simulation tests and ``tools/experiments/sequential_check.py``
(docs/design/sequential-plans.md). :func:`simulate_cells` reads several cells together under a
plan's multiplicity control (``recycling.py``; ``tools/experiments/multiplicity_check.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from d3dwa_bullet.evaluation.plans.looks import (
    A_BETTER,
    B_BETTER,
    EQUIVALENT,
    OPEN,
    decisions,
    first_reading,
    prefix_estimates,
)
from d3dwa_bullet.evaluation.plans.recycling import LevelBounds, Levels, read_look
from d3dwa_bullet.evaluation.plans.student import REPLICATES, rule_boundaries


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


def simulate_cells(
    true: Sequence[float], sd: Sequence[float], n: int, margin: float, k: int, replicates: int,
    seed: int, levels: Levels, bound_replicates: int = REPLICATES,
) -> np.ndarray:  # fmt: skip
    """(replicates, C) the readings (codes of ``looks``; OPEN after the last look is
    inconclusive) of C independent simulated cells read together under ``levels``, each of n
    layouts whose per-layout differences are N(true[c], sd[c]), at k equally spaced looks
    (round(j n / k), j = 1..k). ``levels.cells`` is the plan's m (more than C: cells not
    simulated, which never pass); bound_replicates: the null paths of each level's bounds."""
    mean, spread = np.asarray(true, dtype=float), np.asarray(sd, dtype=float)
    d = np.random.default_rng(seed).normal(
        mean[None, :, None], spread[None, :, None], (replicates, mean.size, n)
    )
    looks = np.round(np.arange(1, k + 1) / k * n).astype(int)
    diff, se, df = prefix_estimates(d, looks)  # each (replicates, C, k)
    bounds = LevelBounds(looks, n, bound_replicates)
    code = np.full((replicates, mean.size), OPEN)
    passed = np.zeros(replicates, dtype=int)
    for j in range(k):
        is_open = code == OPEN
        got, passed, _ = read_look(
            diff[..., j], se[..., j], df[..., j], margin, is_open, passed, levels, bounds, j
        )
        code = np.where(is_open, got, code)
    return code


def false_and_true(
    code: np.ndarray, true: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """code (replicates, C) of cells whose true mean differences are true (C,) -> ((replicates,)
    any false read, (replicates,) the true reads). False: a difference where there is none or in
    the wrong direction, equivalence on or beyond the margin; true: any other read."""
    t = np.asarray(true, dtype=float)[None, :]
    false = ((t <= 0) & (code == A_BETTER)) | ((t >= 0) & (code == B_BETTER))
    false |= (np.abs(t) >= margin) & (code == EQUIVALENT)
    return false.any(axis=1), ((code != OPEN) & ~false).sum(axis=1)
