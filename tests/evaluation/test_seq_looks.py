"""A cell at its looks: the estimate, the decision, the order; validated by simulation."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.plans import (
    ESTIMATORS,
    decisions,
    differences_estimate,
    first_reading,
    layout_order,
    prefix_estimates,
)
from d3dwa_bullet.evaluation.plans.boundaries import maximum_layouts
from d3dwa_bullet.evaluation.plans.looks import A_BETTER, B_BETTER, EQUIVALENT, INCONCLUSIVE, OPEN
from d3dwa_bullet.evaluation.plans.simulate import simulate

ALPHA = 0.05
LOOKS = [5, 10]
"""Equally spaced looks of the simulations: five, and ten as the yardstick's retro-check plan has."""
REPLICATES = 20_000
MC = 3 * np.sqrt(0.05 * 0.95 / REPLICATES)
"""Three Monte Carlo standard errors of a 5 % rate over the replicates: the tests' allowance."""


def _run(
    true: float, n: int, margin: float, seed: int, k: int = 5
) -> tuple[np.ndarray, np.ndarray]:
    """REPLICATES cells of n layouts, per-layout differences N(true, 1), k equally spaced looks."""
    return simulate(true, n, margin, k, REPLICATES, seed, ALPHA)


@pytest.mark.parametrize("k", LOOKS)
def test_no_difference_reads_as_one_at_most_five_per_cent_of_the_time(k: int) -> None:
    reading, _ = _run(0.0, 200, 0.2, seed=1, k=k)
    wrong = np.isin(reading, [A_BETTER, B_BETTER]).mean()
    assert wrong <= ALPHA + MC
    assert (reading == EQUIVALENT).mean() > 0.5  # the margin is 0.2 sd: most cells read equivalent


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_difference_on_the_margin_reads_equivalent_at_most_five_per_cent_of_the_time(
    side: float,
) -> None:
    reading, _ = _run(side * 0.2, 200, 0.2, seed=2)
    assert (reading == EQUIVALENT).mean() <= ALPHA + MC


@pytest.mark.parametrize("k", LOOKS)
def test_power_at_the_design_effect_is_eighty_per_cent(k: int) -> None:
    effect = 0.25  # sd 1: the plan's maximum sized for this effect at 80 % power
    n = maximum_layouts(effect, 1.0, np.arange(1, k + 1) / k, ALPHA / 2, 0.8)
    reading, look = _run(effect, n, 0.05, seed=3, k=k)
    assert (reading == A_BETTER).mean() >= 0.8 - MC
    assert (reading == B_BETTER).mean() < 0.001
    assert np.mean(look[reading == A_BETTER] < k - 1) > 0.5  # most stop before the maximum


def test_the_prefix_estimates_are_the_estimate_of_each_prefix() -> None:
    d = np.random.default_rng(4).normal(0.1, 0.3, size=50)
    diff, se, df = prefix_estimates(d, [5, 20, 50])
    for k, n in enumerate([5, 20, 50]):
        one = differences_estimate(d[:n])
        assert (diff[k], se[k], df[k]) == pytest.approx((one.mean, one.se, one.df))
    flat = prefix_estimates(np.full(10, 0.2) + np.arange(10) * 0.0, [4, 10])
    assert flat[1].tolist() == [0.0, 0.0]  # no spread: the se is 0, not rounding noise


def test_decisions_at_a_look() -> None:
    bound_d, bound_t = 2.0, 1.7
    cases = {  # difference, se -> code (df large: z is t)
        (0.5, 0.1): A_BETTER, (-0.5, 0.1): B_BETTER, (0.0, 0.01): EQUIVALENT,
        (0.0, 0.5): OPEN, (0.02, 0.0): A_BETTER, (0.0, 0.0): EQUIVALENT,
        (0.025, 0.01): A_BETTER,  # a difference inside the margin reads as the difference
    }  # fmt: skip
    for (d, s), code in cases.items():
        assert decisions(np.array(d), np.array(s), np.array(1e6), 0.05, bound_d, bound_t) == code, (
            d,
            s,
        )
    # few degrees of freedom: the same t is weaker evidence
    assert decisions(np.array(0.21), np.array(0.1), np.array(3.0), 0.05, bound_d, bound_t) == OPEN
    assert first_reading(np.array([[OPEN, OPEN], [OPEN, EQUIVALENT], [B_BETTER, OPEN]]))[0].tolist() == [
        INCONCLUSIVE, EQUIVALENT, B_BETTER]  # fmt: skip


def test_each_question_has_its_estimator_and_the_recipe_counts_the_seed_spread() -> None:
    assert set(ESTIMATORS) == {"policies", "recipe"}
    rows = [{"world": f"w{i}", "noise": "none", "seed": 0, "method": m, "outcome": "goal", "score": s}
            for i in range(3) for m, s in (("a", 0.5 + 0.1 * i), ("b", 0.4))]  # fmt: skip
    est = ESTIMATORS["policies"](rows, "a", "b", "score")
    assert est.mean == pytest.approx(0.2) and est.df == 2
    # Two training seeds of a, 0.1 apart on every layout; b fixed: the recipe's se holds the seeds' spread.
    seeded = [
        {
            "world": f"w{i}",
            "noise": "none",
            "seed": 0,
            "method": "a",
            "policy_seed": k,
            "outcome": "goal",
            "score": 0.5 + 0.1 * k + 0.01 * i,
        }
        for i in range(4)
        for k in (0, 1)
    ]
    seeded += [{"world": f"w{i}", "noise": "none", "seed": 0, "method": "b", "outcome": "goal", "score": 0.4}
               for i in range(4)]  # fmt: skip
    policies, recipe_ = (ESTIMATORS[q](seeded, "a", "b", "score") for q in ("policies", "recipe"))
    assert recipe_.mean == pytest.approx(policies.mean) and recipe_.se > policies.se
    with pytest.raises(ResultsError, match="one training seed"):
        ESTIMATORS["recipe"]([r for r in seeded if r.get("policy_seed") != 1], "a", "b", "score")


def test_the_order_is_fixed_by_its_seed_and_interleaves_the_strata() -> None:
    strata = {"barn": [f"B{i}" for i in range(30)], "R1": [f"R{i}" for i in range(90)]}
    order = layout_order(strata, seed=11)
    assert sorted(order) == sorted(strata["barn"] + strata["R1"])
    assert order == layout_order({k: v[::-1] for k, v in strata.items()}, seed=11)
    assert order != layout_order(strata, seed=12)
    for n in (12, 40, 60):  # each prefix holds each stratum in its share, to one layout
        assert abs(sum(x.startswith("B") for x in order[:n]) - n / 4) <= 1
    with pytest.raises(ValueError, match="'B1' is in stratum 'R1'"):
        layout_order({"barn": ["B1"], "R1": ["B1"]}, seed=0)
