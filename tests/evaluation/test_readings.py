"""Readings (docs/design/readings.md#readings): the interval, the one-sided tests and TOST agree with
SciPy and statsmodels on constructed cases; each of the four readings is reached; the
layouts that would decide give the power they name; the edge cases say why."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats
from statsmodels.stats.power import TTestPower
from statsmodels.stats.weightstats import ttost_paired

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.margins import check_margin
from d3dwa_bullet.evaluation.paired import (
    equivalence_power,
    layouts_for_difference,
    layouts_for_equivalence,
    paired_scores,
    units_for_power,
)
from d3dwa_bullet.evaluation.readings import (
    NO_SCORE,
    read_differences,
    reading_of,
    reading_text,
    readings_by_group,
    readings_table,
)

RNG = np.random.default_rng(55)
B_SIDE = RNG.uniform(0.2, 0.8, 60)
CASES = {  # name: (A's per-layout values, B's, margin, expected reading)
    "A better": (B_SIDE[:12] + RNG.normal(0.08, 0.05, 12), B_SIDE[:12], 0.03, "A better"),
    "B better": (B_SIDE[:12] - RNG.normal(0.08, 0.05, 12), B_SIDE[:12], 0.03, "B better"),
    "equivalent": (B_SIDE[:40] + RNG.normal(0.0, 0.02, 40), B_SIDE[:40], 0.03, "equivalent"),
    "inconclusive": (B_SIDE[:8] + RNG.normal(0.01, 0.1, 8), B_SIDE[:8], 0.03, "inconclusive"),
    "both": (B_SIDE + RNG.normal(0.01, 0.01, 60), B_SIDE, 0.03, "A better"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_each_reading_is_scipys_and_statsmodels_figures_read_by_the_rule(name) -> None:
    a, b, margin, expected = CASES[name]
    r = read_differences(a - b, margin)
    n = len(a)
    assert r["reading"] == expected and r["layouts"] == n
    ci = stats.ttest_rel(a, b).confidence_interval(0.95)
    assert (r["low"], r["high"]) == pytest.approx((ci.low, ci.high), rel=1e-10)
    d = a - b  # the interval from the t quantile by hand too
    half = stats.t.ppf(0.975, n - 1) * d.std(ddof=1) / math.sqrt(n)
    assert (r["low"], r["high"]) == pytest.approx((d.mean() - half, d.mean() + half), rel=1e-10)
    assert r["difference"] == pytest.approx(a.mean() - b.mean(), rel=1e-12)
    assert r["p_a_better"] == pytest.approx(stats.ttest_rel(a, b, alternative="greater").pvalue)
    assert r["p_b_better"] == pytest.approx(stats.ttest_rel(a, b, alternative="less").pvalue)
    assert r["tost_p"] == pytest.approx(ttost_paired(a, b, -margin, margin)[0], rel=1e-10)
    # the rule, from the library figures alone
    lib_tost = ttost_paired(a, b, -margin, margin)[0]
    assert r["equivalent"] == (lib_tost < 0.05)
    if expected == "A better":
        assert ci.low > 0  # the reading and the printed 95 % interval agree
    if name == "both":
        assert r["equivalent"] and reading_text(r | {"metric": "score"}) == (
            "A better; also within ±0.03"
        )
    if expected == "inconclusive":
        assert r["needed"] == min(r["needed_difference"], r["needed_equivalence"]) > n
    else:
        assert r["needed"] is None


def test_the_texts_of_the_four_readings() -> None:
    texts = {
        name: reading_text(read_differences(a - b, m) | {"metric": "success"})
        for name, (a, b, m, _) in CASES.items()
    }
    assert texts["A better"] == "A better" and texts["B better"] == "B better"
    assert texts["equivalent"] == "equivalent within ±3 points"
    needed = read_differences(CASES["inconclusive"][0] - CASES["inconclusive"][1], 0.03)["needed"]
    assert texts["inconclusive"] == f"inconclusive (about {needed} layouts would decide)"


def test_the_layouts_for_a_difference_are_statsmodels_power_in_the_normal_limit() -> None:
    # the normal approximation asks for a little less than the noncentral t, and the gap
    # stays at about the two units the t's heavier tail costs
    for mean, sd in ((0.05, 0.2), (0.02, 0.15), (-0.1, 0.3)):
        n = layouts_for_difference(mean, sd, 0.025, 0.8)
        exact = TTestPower().solve_power(abs(mean) / sd, alpha=0.025, power=0.8,
                                         alternative="larger")  # fmt: skip
        assert n < exact < n + 3
    assert layouts_for_difference(0.0, 0.1, 0.025) == math.inf


def test_the_layouts_for_equivalence_give_their_power_in_simulation() -> None:
    mean, sd, margin = 0.01, 0.05, 0.03
    n = layouts_for_equivalence(mean, sd, margin, 0.05, 0.8)
    assert equivalence_power(n, mean, sd, margin, 0.05) == pytest.approx(0.8, abs=1e-6)
    k = math.ceil(n)
    draws = np.random.default_rng(0).normal(mean, sd, (4000, k))
    lower = stats.ttest_1samp(draws, -margin, axis=1, alternative="greater").pvalue
    upper = stats.ttest_1samp(draws, margin, axis=1, alternative="less").pvalue
    assert (np.maximum(lower, upper) < 0.05).mean() == pytest.approx(0.8, abs=0.04)
    # centred, both sides bind: more than the one-sided formula alone would ask
    one_sided = ((stats.norm.ppf(0.95) + stats.norm.ppf(0.8)) * sd / margin) ** 2
    assert layouts_for_equivalence(0.0, sd, margin, 0.05) > one_sided
    assert layouts_for_equivalence(0.03, sd, margin, 0.05) == math.inf


def test_fewer_than_two_layouts_no_spread_and_nan_say_why() -> None:
    one = read_differences([0.4], 0.03) | {"metric": "success"}
    assert one["reading"] == "inconclusive" and one["difference"] == 0.4
    assert reading_text(one) == "inconclusive (1 layout: a test paired by layout needs 2 or more)"
    flat = read_differences([0.0, 0.0, 0.0], 0.03)
    assert flat["reading"] == "equivalent" and flat["tost_p"] == 0.0 and flat["p_a_better"] == 1.0
    assert flat["why"] == "no spread: every layout differs by 0"
    ahead = read_differences([1.0, 1.0], 0.03)
    assert ahead["reading"] == "A better" and not ahead["equivalent"]
    nan = read_differences([0.1, float("nan"), 0.2], 0.03) | {"metric": "score"}
    assert (
        nan["reading"] is None and reading_text(nan) == "no reading: 1 of 3 layouts have no value"
    )
    assert all(v is None or not (isinstance(v, float) and math.isnan(v)) for v in nan.values())


def test_differences_equal_but_for_rounding_have_no_spread_and_warn_nothing() -> None:
    d = [0.8 - 0.6, 1.0 - 0.8, 0.4 - 0.2]  # 0.2 each, a sample sd of about 6.5e-17
    assert np.std(d, ddof=1) > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # SciPy warns of catastrophic cancellation on these
        out = read_differences(d, 0.03)
    assert out["sd"] == 0.0 and out["reading"] == "A better"
    assert out["why"] == "no spread: every layout differs by 0.2"
    assert units_for_power({k: (v, 0.0) for k, v in enumerate(d)}) is None
    spread = read_differences([0.2, 0.2 + 1e-6, 0.2], 0.03)  # a spread a millionth wide is one
    assert spread["sd"] > 0 and spread["why"] is None


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), 101.0])
def test_a_margin_that_is_not_a_positive_finite_number_is_refused(value) -> None:
    with pytest.raises(ConfigError, match="--margin-success must be a positive finite number"):
        check_margin(value, "success")
    assert check_margin(3.0, "success") == 0.03 and check_margin(0.5, "score") == 0.5


def _row(method, world, seed, goal, score, policy_seed=None):
    return {"method": method, "world": world, "noise": "none", "seed": seed,
            "policy_seed": policy_seed, "outcome": "goal" if goal else "timeout",
            "score": score if goal else 0.0, "score_barn": 0.125 if goal else 0.0}  # fmt: skip


def test_readings_pair_by_layout_on_the_score_and_say_when_rows_lack_it() -> None:
    rows = []
    for k in range(6):
        w = f"L{k}"
        for s in (0, 1):
            rows += [_row("a", w, s, True, 0.5 + 0.01 * k + 0.02 * t, t) for t in (0, 1)]
            rows.append(_row("b", w, s, k % 2 == 0, 0.4 + 0.01 * s))
    scores = paired_scores(rows, "a", "b", by_seed=False, metric="score")
    assert scores[("L1", "none", None)] == pytest.approx((0.52, 0.0))
    assert scores[("L0", "none", None)] == pytest.approx((0.51, 0.405))
    margins = {"success": 0.03, "score": 0.03, "score_barn": 0.01}
    out = readings_by_group(rows, "a", "b", {u: ["odd" if u[0] in ("L1", "L3", "L5") else "even"]
                                             for u in scores}, margins)  # fmt: skip
    assert set(out) == {"odd", "even", "all"} and out["all"]["score"]["layouts"] == 6
    expected = reading_of(scores, 0.03)
    for key in ("difference", "low", "high", "p_a_better", "tost_p", "mean_a", "mean_b"):
        assert out["all"]["score"][key] == pytest.approx(expected[key], rel=1e-12)
    assert out["all"]["score"]["reading"] == expected["reading"] == "A better"
    assert out["odd"]["success"]["reading"] == "A better"  # 1 - 0 on each: no spread
    old = [{k: v for k, v in r.items() if k not in ("score", "score_barn")} for r in rows]
    lacking = readings_by_group(old, "a", "b", {}, margins)["all"]
    assert lacking["score"]["why"] == NO_SCORE and reading_text(lacking["score_barn"]) == NO_SCORE
    assert lacking["success"]["reading"] == out["all"]["success"]["reading"]


def test_an_interval_stays_inside_what_a_difference_can_be_or_is_none_with_why() -> None:
    two = read_differences([-1.0, 0.0], 0.03) | {"metric": "success"}  # t interval: [-6.9, +5.9]
    assert two["low"] is None and two["high"] is None and two["difference"] == -0.5
    assert two["why"].startswith("no interval: on 2 layouts") and two["reading"] == "inconclusive"
    table = readings_table({"all": {"success": two}})
    assert "-50.0 (no interval on 2 layouts)" in table and "-685" not in table
    wide = read_differences([1.0, 1.0, 0.0, 1.0], 0.03)  # t interval's top beyond +1
    t_high = stats.ttest_1samp([1.0, 1.0, 0.0, 1.0], 0.0).confidence_interval(0.95).high
    assert t_high > 1.0 and wide["high"] == 1.0 and -1.0 < wide["low"] < wide["difference"]


def test_identical_methods_read_equivalent_with_the_no_spread_note() -> None:
    same = read_differences([0.0] * 5, 0.03) | {"metric": "success"}
    assert reading_text(same) == "equivalent within ±3 points (no spread)"
