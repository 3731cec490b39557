"""The sizing of a recipe-level cell: components recovered, power rising, the cheapest design."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.evaluation.recipe import recipe_arrays
from d3dwa_bullet.evaluation.recipe_sizing import (
    Components,
    cheapest,
    components,
    design_se_df,
    power,
)


def test_components_recover_known_variances():
    rng = np.random.default_rng(0)
    s, n = 40, 400  # many seeds and layouts: the moments settle
    layout = rng.normal(0, 0.1, n)
    a = 0.05 + rng.normal(0, 0.08, (s, 1)) + layout + rng.normal(0, 0.2, (s, n))
    b = rng.normal(0, 0.0001, (1, n)) + layout + rng.normal(0, 0.15, (1, n))
    c = components(a, b)
    assert c.seed_a == pytest.approx(0.08**2, rel=0.35)
    assert c.resid_a == pytest.approx(0.2**2, rel=0.05)
    assert c.layout == pytest.approx(0.15**2, rel=0.2)  # B's own noise sits in the layout term
    assert (c.learned, c.fixed, c.seed_b, c.resid_b) == (1, 1, 0.0, 0.0)


def test_design_se_matches_the_estimate_at_the_pilots_own_size():
    """At the pilot's (S, L), the design's se is the expectation of the estimate's se."""
    rng = np.random.default_rng(1)
    a = 0.03 + rng.normal(0, 0.05, (2000, 5, 1)) + rng.normal(0, 0.2, (2000, 5, 100))
    b = rng.normal(0, 0.05, (2000, 5, 1)) + rng.normal(0, 0.2, (2000, 5, 100))
    _, se, _ = recipe_arrays(a, b)
    c = Components(0.03, 0.05**2, 0.05**2, 0.2**2, 0.2**2, 0.0, 2, 0)
    assert design_se_df(c, 5, 100)[0] == pytest.approx(float(np.sqrt(np.mean(se**2))), rel=0.05)


def test_power_rises_with_seeds_and_layouts_and_seed_variance_sets_a_floor():
    c = Components(0.05, 0.002, 0.0, 0.04, 0.0, 0.01, 1, 1)
    assert power(c, 5, 100, "difference", 0.03) < power(c, 5, 1000, "difference", 0.03)
    assert power(c, 5, 1000, "difference", 0.03) < power(c, 20, 1000, "difference", 0.03)
    # 5 seeds: se >= sqrt(0.002 / 5) = 0.02 whatever L, so 0.05 reads with power < 80 %
    assert power(c, 5, 10**6, "difference", 0.03) < 0.8


def test_cheapest_trades_seeds_for_layouts_by_cost():
    c = Components(0.05, 0.002, 0.0, 0.04, 0.0, 0.01, 1, 1)
    cheap_seeds = cheapest(c, 0.03, train_minutes=1.0, episode_seconds=10.0)
    dear_seeds = cheapest(c, 0.03, train_minutes=600.0, episode_seconds=0.1)
    assert cheap_seeds["aim"] == "difference" and cheap_seeds["power"] >= 0.8
    assert (
        cheap_seeds["seeds"] > dear_seeds["seeds"]
        and cheap_seeds["layouts"] < dear_seeds["layouts"]
    )
    nothing = Components(0.0, 0.01, 0.01, 0.04, 0.04, 0.01, 2, 0)
    assert "why" in cheapest(nothing, 0.001, 10.0, 1.0, most_seeds=5, most_layouts=1000)
