"""Lan-DeMets O'Brien-Fleming boundaries against published values and SciPy's multivariate normal."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from d3dwa_bullet.evaluation.plans import (
    boundaries,
    crossing_probability,
    drift_for_power,
    spending,
)
from d3dwa_bullet.evaluation.plans.boundaries import maximum_layouts

# One-sided alpha 0.025, K equally spaced looks, Lan-DeMets O'Brien-Fleming spending: the upper
# bounds as published for gsDesign's sfLDOF (Anderson, gsDesign manual) and in Jennison &
# Turnbull (2000) ch. 7's examples.
PUBLISHED_LDOF = {
    2: [2.9626, 1.9686],
    3: [3.7103, 2.5114, 1.9930],
    4: [4.3326, 2.9631, 2.3590, 2.0141],
    5: [4.8769, 3.3569, 2.6803, 2.2898, 2.0310],
}
# Jennison & Turnbull (2000) Table 2.3: O'Brien-Fleming's constant C_B(K, 0.05), two-sided
# alpha 0.05, K equally spaced looks; the bound at look k is C_B sqrt(K / k).
PUBLISHED_OBF = {2: 1.977, 3: 2.004, 4: 2.024, 5: 2.040}


@pytest.mark.parametrize("k", sorted(PUBLISHED_LDOF))
def test_boundaries_match_the_published_ones(k: int) -> None:
    t = np.arange(1, k + 1) / k
    assert boundaries(t, 0.025) == pytest.approx(PUBLISHED_LDOF[k], abs=2e-4)


@pytest.mark.parametrize("k", sorted(PUBLISHED_OBF))
def test_the_integration_gives_obrien_flemings_level(k: int) -> None:
    t = np.arange(1, k + 1) / k
    bounds = PUBLISHED_OBF[k] * np.sqrt(k / np.arange(1, k + 1))
    # two-sided: twice one side (crossing both ways is out of reach); the table has 3 decimals
    assert 2 * crossing_probability(bounds, t).sum() == pytest.approx(0.05, abs=5e-4)


def test_scipys_multivariate_normal_agrees_at_unequal_looks() -> None:
    t = np.array([0.2, 0.45, 0.7, 1.0])
    c = boundaries(t, 0.05)
    cov = np.sqrt(np.minimum.outer(t, t) / np.maximum.outer(t, t))
    rng = np.random.default_rng(3)
    for k in range(1, t.size + 1):  # the chance of any crossing by look k is what was spent
        law = stats.multivariate_normal(np.zeros(k), cov[:k, :k], abseps=1e-7, seed=rng)
        below = law.cdf(c[:k])
        assert 1 - below == pytest.approx(float(spending(t[k - 1], 0.05)), abs=2e-5)


def test_the_last_look_spends_all_alpha_and_the_first_spends_little() -> None:
    t = np.array([0.1, 0.5, 1.0])
    c = boundaries(t, 0.05)
    assert crossing_probability(c, t).sum() == pytest.approx(0.05, abs=1e-5)
    assert c[0] > 4 and c[-1] < stats.norm.isf(0.05) + 0.1  # early hard, last near the fixed-N z
    assert boundaries(t[:2], 0.05) == pytest.approx(c[:2])  # a look's bound ignores later looks
    one = boundaries([1.0], 0.05)
    assert one == pytest.approx([stats.norm.isf(0.05)])  # one look: the fixed-N test


def test_power_and_the_maximum_it_needs() -> None:
    t = np.arange(1, 6) / 5
    drift = drift_for_power(t, 0.025, 0.8)
    fixed = stats.norm.isf(0.025) + stats.norm.isf(0.2)
    assert fixed < drift < 1.05 * fixed  # O'Brien-Fleming's inflation is a few per cent
    assert crossing_probability(boundaries(t, 0.025), t, drift).sum() == pytest.approx(
        0.8, abs=1e-6
    )
    assert maximum_layouts(0.25, 1.0, t, 0.025, 0.8) >= int(
        np.ceil((drift / 0.25) ** 2)
    )  # t: a few more
    with pytest.raises(ValueError, match="non-zero effect"):
        maximum_layouts(0.0, 1.0, t, 0.025, 0.8)


def test_bad_fractions_are_refused() -> None:
    with pytest.raises(ValueError, match="must increase"):
        boundaries([0.5, 0.5, 1.0], 0.05)
    with pytest.raises(ValueError, match="must increase"):
        boundaries([0.5, 1.2], 0.05)
