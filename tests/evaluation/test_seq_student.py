"""Boundaries for the t: the spread re-estimated at each look, the level still held."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from d3dwa_bullet.evaluation.plans import boundaries, spending
from d3dwa_bullet.evaluation.plans.student import null_tails, t_boundaries

SMALL = np.arange(1, 11) * 4
"""Ten looks of 4 layouts each up to 40: few degrees of freedom, where normal bounds read too often."""
CHECK = 500_000
"""Independent null paths of the level checks (other seeds than the bounds'): one standard error of
a 2.5 % rate is 2.2e-4."""


def _crossed(bounds: list[np.ndarray], looks: np.ndarray, seed: int) -> list[float]:
    """For each of ``bounds`` (z scale, (K,) each), the share of the same CHECK fresh null paths
    whose t crosses it at some look."""
    floor = float(min(b.min() for b in bounds)) - 0.1
    path, look, value = null_tails(tuple(int(n) for n in looks), CHECK, seed, floor)[0]
    return [np.unique(path[value >= b[look]]).size / CHECK for b in bounds]


def test_the_difference_test_holds_five_per_cent_where_normal_bounds_do_not() -> None:
    one_side = 0.025
    mc = 3 * np.sqrt(one_side * (1 - one_side) / CHECK)
    b, normal = t_boundaries(SMALL, 40, one_side), boundaries(SMALL / 40, one_side)
    (up, up_normal), (down,) = _crossed([b, normal], SMALL, seed=1), _crossed([b], SMALL, seed=2)
    # both directions, each on its own paths: the sum counts a path crossing both ways twice (conservative)
    assert up + down <= 2 * one_side + 2 * mc
    assert abs(up + down - 2 * one_side) < 2 * mc  # not bought by a stricter bound than needed
    # on the same paths the normal bounds read more often, by about the excess they have (0.001)
    assert up_normal - up > 5e-4
    assert b[-1] > normal[-1]


def test_with_many_layouts_a_look_the_bounds_are_the_published_normal_ones() -> None:
    looks = np.arange(1, 6) * 100_000  # df in the hundreds of thousands: the t is the z
    published = [4.8769, 3.3569, 2.6803, 2.2898, 2.0310]  # gsDesign sfLDOF, one-sided 0.025, K = 5
    assert t_boundaries(looks, 500_000, 0.025, replicates=200_000) == pytest.approx(
        published, abs=2e-3
    )


def test_the_first_bound_is_exact_and_later_looks_do_not_move_earlier_bounds() -> None:
    b = t_boundaries(SMALL[:4], 40, 0.05, replicates=200_000)
    assert b[0] == pytest.approx(stats.norm.isf(float(spending(0.1, 0.05))))
    assert t_boundaries(SMALL[:2], 40, 0.05, replicates=200_000) == pytest.approx(b[:2])
    assert t_boundaries(SMALL[:4], 40, 0.05, replicates=200_000).tolist() == b.tolist()  # seeded


def test_a_look_of_one_layout_is_refused() -> None:
    with pytest.raises(ValueError, match="2 or more layouts"):
        t_boundaries([1, 4], 4, 0.05)
    with pytest.raises(ValueError, match="increase"):
        t_boundaries([4, 4, 8], 8, 0.05)
