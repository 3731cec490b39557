"""Statistics over training seeds against values computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.evaluation.seed_stats import (
    iqm,
    iqm_interval,
    mean_interval,
    probability_of_improvement,
)


def test_success_interval_over_seeds_matches_the_exact_bootstrap() -> None:
    # 3 of 5 seeds succeed: the bootstrap mean is Binomial(5, 0.6) / 5, whose 2.5 % and
    # 97.5 % quantiles are 1/5 (P(K <= 0) = 1.0 % < 2.5 % < P(K <= 1) = 8.7 %) and 5/5
    # (P(K <= 4) = 92.2 % < 97.5 %).
    value, low, high = mean_interval([[1, 0, 1, 1, 0]])
    assert value == pytest.approx(0.6)
    assert (low, high) == pytest.approx((0.2, 1.0))


def test_the_interval_covers_the_training_seed_spread_and_is_stratified() -> None:
    # task A's seeds spread 0.2..1.0 (mean 0.6), task B always fails: the mean over tasks is
    # 0.3, and resampling A's seeds alone moves it within [0.1, 0.5]
    value, low, high = mean_interval([[0.2, 0.4, 0.6, 0.8, 1.0], [0, 0, 0, 0, 0]])
    assert value == pytest.approx(0.3)
    assert 0.1 <= low < 0.3 < high <= 0.5
    assert mean_interval([[0.2, 0.4, 0.6, 0.8, 1.0], [0, 0, 0, 0, 0]]) == (value, low, high)


def test_iqm_by_hand() -> None:
    assert iqm(np.arange(1, 9)) == pytest.approx((3 + 4 + 5 + 6) / 4)
    value, low, high = iqm_interval([[1, 2, 3, 4], [5, 6, 7, 8]])
    assert value == pytest.approx(4.5)
    assert low < 4.5 < high
    assert iqm_interval([[7.0, 7.0]]) == (7.0, 7.0, 7.0)  # nothing to resample


def test_probability_of_improvement_by_hand() -> None:
    # task 1: every run of X beats every run of Y (1); task 2: always tied (0.5)
    value, low, high = probability_of_improvement([[1, 1], [0.5]], [[0, 0], [0.5]])
    assert (value, low, high) == pytest.approx((0.75, 0.75, 0.75))
    # 2 of X's 3 runs beat Y's one run, the third loses: 2/3
    value, low, high = probability_of_improvement([[3, 2, 0]], [[1]])
    assert value == pytest.approx(2 / 3) and 0 <= low <= value <= high <= 1


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="at least one"):
        mean_interval([])
    with pytest.raises(ValueError, match="finite"):
        mean_interval([[np.nan, 1]])
    with pytest.raises(ValueError, match="tasks"):
        probability_of_improvement([[1]], [[1], [0]])


def _one_at_a_time(tasks, statistic):
    """The stratified bootstrap with a scalar statistic called once per resample (SciPy's
    unvectorised path): what the vectorised intervals must equal, value for value."""
    from scipy import stats

    tasks = [np.asarray(t, dtype=np.float64) for t in tasks]
    free = [i for i, t in enumerate(tasks) if np.ptp(t) > 0]

    def resampled(*xs):
        full = list(tasks)
        for i, x in zip(free, xs, strict=True):
            full[i] = x
        return statistic(full)

    result = stats.bootstrap([tasks[i] for i in free], resampled, n_resamples=2000,
                             confidence_level=0.95, method="percentile", vectorized=False,
                             paired=False, rng=np.random.default_rng(0))  # fmt: skip
    return result.confidence_interval.low, result.confidence_interval.high


def test_the_vectorised_bootstrap_gives_the_one_at_a_time_interval_exactly() -> None:
    rng = np.random.default_rng(7)
    for n_tasks in (2, 3, 9, 50):  # 8 and more tasks: the sum's order matters to the last bit
        tasks = [rng.random(rng.integers(2, 6)) * 40 for _ in range(n_tasks)]
        tasks[0] = np.full(3, 5.0)  # a task that repeats: held fixed, not resampled
        others = [rng.integers(0, 2, 5).astype(float) for _ in range(n_tasks)]
        mean = _one_at_a_time(tasks, lambda full: np.mean([np.mean(t) for t in full]))
        assert mean_interval(tasks)[1:] == mean
        pooled = _one_at_a_time(tasks, lambda full: iqm(np.concatenate(full)))
        assert iqm_interval(tasks)[1:] == pooled

        def p_of_improvement(full, n=n_tasks):
            d = [full[i][:, None] - full[n + i][None, :] for i in range(n)]
            return np.mean([np.mean(x > 0) + 0.5 * np.mean(x == 0) for x in d])

        assert probability_of_improvement(tasks, others)[1:] == _one_at_a_time(
            [*tasks, *others], p_of_improvement
        )
