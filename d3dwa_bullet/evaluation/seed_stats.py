"""Statistics over training seeds (docs/design/learning-protocol.md#learning-protocol), pure numpy and SciPy.

A method's result is a distribution over training runs, so every interval here resamples
*training seeds*: a run's own evaluation episodes are averaged into one score per seed
first. Across several tasks (worlds) the bootstrap is stratified: seeds are resampled
within each task, independently, as in Agarwal et al. (2021), "Deep Reinforcement Learning
at the Edge of the Statistical Precipice". The resampling is SciPy's
(``scipy.stats.bootstrap``, percentile intervals, a seeded generator), not our own.

- ``mean_interval``: the mean over tasks of each task's mean score (e.g. success rate),
  with its stratified bootstrap interval;
- ``iqm_interval``: the interquartile mean (25 % trimmed from each end) of all scores
  pooled, with its stratified bootstrap interval;
- ``probability_of_improvement``: P(X > Y), the chance that a run of method X scores above
  a run of Y on a task (ties count half), averaged over tasks, with its interval.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
RESAMPLES = 2000
SEED = 0
"""Fixed, so the same results give the same interval."""
VECTORISED = True
"""SciPy hands the statistics a batch of resamples at once; False: one resample at a time,
the same interval far slower (tools/bench/bench_report.py measures the two)."""


class Interval(NamedTuple):
    """A point estimate with its confidence interval."""

    value: float
    low: float
    high: float


def _tasks(scores: Sequence[Sequence[float]] | np.ndarray) -> list[np.ndarray]:
    """Per-task score arrays (one score per training seed), checked."""
    tasks = [np.asarray(s, dtype=np.float64).ravel() for s in scores]
    if not tasks or any(t.size == 0 for t in tasks):
        raise ValueError("seed_stats: need at least one task with at least one seed score")
    if any(not np.isfinite(t).all() for t in tasks):
        raise ValueError("seed_stats: scores must be finite")
    return tasks


def iqm(values: np.ndarray) -> float:
    """Interquartile mean: the mean of the middle half (scipy's 25 % trimmed mean)."""
    return float(stats.trim_mean(np.asarray(values, dtype=np.float64), 0.25))


# The statistics below take one array per task, each either one score per seed (n,) or a
# batch of resamples (..., n), and reduce along the last axis only, in the same order for
# both: a batch of resamples gives, value for value, what each resample alone would (the
# bootstrap runs vectorised, ~50x faster on a 50-world page, the same interval).


def _mean_of_means(*xs: np.ndarray) -> np.ndarray:
    return np.mean(np.stack([np.mean(x, axis=-1) for x in xs], axis=-1), axis=-1)


def _pooled_iqm(*xs: np.ndarray) -> np.ndarray:
    return stats.trim_mean(np.concatenate(xs, axis=-1), 0.25, axis=-1)


def _improvement(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """P(X > Y) + 0.5 P(X = Y) over all pairs of a run of X and a run of Y."""
    diff = x[..., :, None] - y[..., None, :]
    return np.mean(diff > 0, axis=(-2, -1)) + 0.5 * np.mean(diff == 0, axis=(-2, -1))


def _bootstrap(
    tasks: list[np.ndarray], statistic, confidence: float, resamples: int, seed: int
) -> tuple[float, float]:
    if all(t.size == 1 for t in tasks) or all(np.ptp(t) == 0 for t in tasks):
        value = float(statistic(*tasks))  # nothing to resample: the interval is the point
        return value, value
    # A task with one seed, or with every seed the same, resamples to itself: keep it fixed
    # (SciPy needs two or more; and a method whose episode repeats at every evaluation seed
    # then gives the same interval from its one run as from its repeats: evaluation.repeats).
    free = [i for i, t in enumerate(tasks) if np.ptp(t) > 0]

    def resampled(*xs: np.ndarray, axis: int = -1) -> np.ndarray:
        batch = xs[0].shape[:-1]  # SciPy hands over a batch of resamples of each free task
        full = [np.broadcast_to(t, (*batch, t.size)) for t in tasks]
        for i, x in zip(free, xs, strict=True):
            full[i] = x
        return statistic(*full)

    result = stats.bootstrap(
        [tasks[i] for i in free],
        resampled,
        n_resamples=resamples,
        confidence_level=confidence,
        method="percentile",
        vectorized=VECTORISED,
        paired=False,  # each task's seeds are resampled on their own: a stratified bootstrap
        rng=np.random.default_rng(seed),
    )
    return float(result.confidence_interval.low), float(result.confidence_interval.high)


def _interval(
    tasks: list[np.ndarray], statistic, confidence: float, resamples: int, seed: int
) -> Interval:
    low, high = _bootstrap(tasks, statistic, confidence, resamples, seed)
    return Interval(float(statistic(*tasks)), low, high)


def mean_interval(
    scores: Sequence[Sequence[float]],
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = SEED,
) -> Interval:
    """Mean over tasks of the per-task mean score; scores[task] holds one score per seed."""
    return _interval(_tasks(scores), _mean_of_means, confidence, resamples, seed)


def iqm_interval(
    scores: Sequence[Sequence[float]],
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = SEED,
) -> Interval:
    """IQM of all scores pooled over tasks, with the stratified bootstrap interval."""
    return _interval(_tasks(scores), _pooled_iqm, confidence, resamples, seed)


def probability_of_improvement(
    x_scores: Sequence[Sequence[float]],
    y_scores: Sequence[Sequence[float]],
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = SEED,
) -> Interval:
    """P(X > Y) averaged over tasks; x_scores[task], y_scores[task] one score per seed."""
    xs, ys = _tasks(x_scores), _tasks(y_scores)
    if len(xs) != len(ys):
        raise ValueError(f"seed_stats: {len(xs)} tasks for X but {len(ys)} for Y")
    n = len(xs)

    def statistic(*samples: np.ndarray) -> np.ndarray:
        per_task = [_improvement(samples[i], samples[n + i]) for i in range(n)]
        return np.mean(np.stack(per_task, axis=-1), axis=-1)

    return _interval([*xs, *ys], statistic, confidence, resamples, seed)
