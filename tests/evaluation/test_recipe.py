"""The recipe-level reading: simulated coverage and type I, fixed sides, refusals, plain numbers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.readings import read_differences
from d3dwa_bullet.evaluation.recipe import (
    Estimate,
    both_readings,
    policies_arrays,
    read_estimate,
    recipe_arrays,
    recipe_estimate,
)
from tools.experiments.recipe_coverage import CASES, REPLICATES, coverage, simulate

MC_ERROR = 2 * np.sqrt(0.05 * 0.95 / REPLICATES)
"""Two Monte Carlo standard errors of a 5 % rate over REPLICATES (0.7 points)."""
_simulate, _coverage = simulate, coverage


@pytest.mark.parametrize("case", CASES)
def test_recipe_interval_covers_the_recipe_truth_95_percent(case):
    """The 95 % interval covers the true A - B (over seeds and layouts) 95 +- 2 % of the time."""
    a, b = _simulate(*case, delta=0.04, seed=1)
    assert 0.93 <= _coverage(recipe_arrays, a, b, delta=0.04) <= 0.97


@pytest.mark.parametrize("case", [c for c in CASES if c[0] >= 3])
def test_recipe_reads_a_difference_at_most_5_percent_when_there_is_none(case):
    """With three or more seeds a side, no true difference is read as A or B better at most 5 %
    of the time (within the simulation's own error)."""
    a, b = _simulate(*case, seed=2)
    mean, se, df = recipe_arrays(a, b)
    p_a, p_b = stats.t.sf(mean / se, df), stats.t.cdf(mean / se, df)
    assert float(np.mean((p_a < 0.025) | (p_b < 0.025))) <= 0.05 + MC_ERROR


def test_two_seeds_type_one_is_near_but_above_5_percent():
    """Two seeds a side: the Satterthwaite interval is slightly short (the known limit, stated
    in docs/design/readings-recipe.md): type I within 5-8 %, never far off."""
    a, b = _simulate(*CASES[3], seed=2)
    mean, se, df = recipe_arrays(a, b)
    rate = float(np.mean(np.abs(mean) > stats.t.ppf(0.975, df) * se))
    assert 0.03 <= rate <= 0.08


def test_these_policies_miss_the_recipe_truth_when_seed_variance_is_large():
    """The point of issue 77: today's interval (seeds fixed) covers the recipe's truth far less
    than 95 % when seeds vary a lot; the recipe's covers it."""
    a, b = _simulate(5, 300, 0.05, 0.05, 0.1, 0.2, seed=3)
    assert _coverage(policies_arrays, a, b) < 0.6
    assert 0.93 <= _coverage(recipe_arrays, a, b) <= 0.97


def test_recipe_se_is_never_below_today_and_tends_to_per_seed_means_t():
    a, b = _simulate(5, 100, 0.1, 0.1, 0.1, 0.05, seed=4)
    _, se_r, df_r = recipe_arrays(a, b)
    _, se_p, _ = policies_arrays(a, b)
    assert np.all(se_r >= se_p - 1e-12)
    # seed variance dominating: se is the per-seed means' Welch se, df near 2 (S - 1)
    welch = np.sqrt(a.mean(-1).var(-1, ddof=1) / 5 + b.mean(-1).var(-1, ddof=1) / 5)
    assert np.median(np.abs(se_r / welch - 1)) < 0.05
    assert 4 <= np.median(df_r) <= 8.5


def test_recipe_estimate_is_plain_numbers_and_reads_like_today_without_seeds():
    rng = np.random.default_rng(5)
    a = rng.normal(0.1, 0.2, (1, 40))
    b = rng.normal(0.0, 0.2, (1, 40))
    est = recipe_estimate(a, b)
    assert isinstance(est, Estimate) and all(
        isinstance(x, float) for x in (est.mean, est.se, est.df)
    )
    assert est.df == 39.0
    mine, today = read_estimate(est, 0.03), read_differences(a[0] - b[0], 0.03)
    for key in ("low", "high", "p_a_better", "p_b_better", "tost_p", "reading"):
        assert mine[key] == pytest.approx(today[key])


def test_read_estimate_rule_and_limits():
    assert read_estimate(Estimate(0.1, 0.01, 10), 0.03)["reading"] == "A better"
    assert read_estimate(Estimate(-0.1, 0.01, 10), 0.03)["reading"] == "B better"
    assert read_estimate(Estimate(0.001, 0.005, 50), 0.03)["reading"] == "equivalent"
    inc = read_estimate(Estimate(0.01, 0.05, 4), 0.03)
    assert inc["reading"] == "inconclusive" and "recipe_sizing" in inc["why"]
    assert read_estimate(Estimate(0.02, 0.0, np.inf), 0.03)["reading"] == "A better"


def _rows(method, seeds, worlds, value, noise="none"):
    return [{"method": method, "policy_seed": s, "seed": 0, "world": w, "noise": noise, "outcome": "goal",
             "score": value(s, w)} for s in seeds for w in worlds]  # fmt: skip


def test_both_readings_from_rows_and_fixed_side():
    worlds = [f"W{i}" for i in range(30)]
    rng = np.random.default_rng(6)
    noise = {(s, w): rng.normal(0, 0.05) for s in range(3) for w in worlds}
    rows = _rows("learned", [0, 1, 2], worlds, lambda s, w: 0.6 + 0.05 * s + noise[(s, w)])
    rows += _rows("dwa3", [""], worlds, lambda s, w: 0.55)
    out = both_readings(rows, "learned", "dwa3", "score", 0.03)
    assert set(out) == {"policies", "recipe"}
    assert out["recipe"]["seeds_a"] == 3 and out["recipe"]["seeds_b"] == 0
    assert out["recipe"]["layouts"] == 30
    assert out["recipe"]["se"] > out["policies"]["sd"] / np.sqrt(30)
    assert out["policies"]["reading"] == "A better"


def test_one_seed_learned_side_is_refused_naming_method_and_seed():
    rows = _rows("learned", [4], ["W0", "W1"], lambda s, w: 0.5) + _rows(
        "dwa3", [""], ["W0", "W1"], lambda s, w: 0.4
    )
    with pytest.raises(ResultsError, match=r"'learned' has one training seed \(4\)"):
        both_readings(rows, "learned", "dwa3", "score", 0.03)


def test_two_fixed_sides_have_no_recipe_question():
    rows = _rows("dwa1", [""], ["W0", "W1", "W2"], lambda s, w: 0.5)
    rows += _rows("dwa3", [""], ["W0", "W1", "W2"], lambda s, w: 0.4 + 0.01 * int(w[1]))
    assert set(both_readings(rows, "dwa1", "dwa3", "score", 0.03)) == {"policies"}
