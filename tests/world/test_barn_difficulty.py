"""BARN difficulty measures on grids whose answers are known, and the fixed terciles."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.world.barn import path_length, read_world_file, world_file
from d3dwa_bullet.world.barn_difficulty import (
    TERCILE_MEASURE,
    TERCILES,
    barn_difficulty,
    barn_tercile,
    barn_tercile_group,
    difficulty_of,
    narrowest_width,
    path_clearance,
)


def corridor(low: int, high: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows low and high filled across the grid; the path runs along the middle row."""
    grid = np.zeros((30, 30), dtype=bool)
    grid[[low, high]] = True
    mid = (low + high) // 2
    path = np.column_stack((np.full(30, mid), np.arange(30)))
    return grid, path


def test_clearance_and_width_of_a_straight_corridor():
    grid, path = corridor(10, 16)  # centres 6 cells apart, path 3 cells from each wall
    assert path_clearance(grid, path) == pytest.approx(np.full(30, 3 * 0.15 - 0.075))
    # across the corridor: 6 cells centre to centre, less one diameter
    assert narrowest_width(grid, path) == pytest.approx(np.full(30, 6 * 0.15 - 0.15))


def test_a_wider_corridor_is_easier_on_every_measure_but_tortuosity():
    narrow, wide = difficulty_of(*corridor(10, 16)), difficulty_of(*corridor(8, 20))
    assert wide.clearance_mean > narrow.clearance_mean
    assert wide.clearance_min > narrow.clearance_min
    assert wide.characteristic_dimension > narrow.characteristic_dimension


def test_tortuosity_is_the_reference_length_over_ten_metres():
    _, path = read_world_file(world_file(17))
    assert barn_difficulty(17).tortuosity == pytest.approx(path_length(path) / 10.0)
    assert barn_difficulty(17).tortuosity > 1.0


def test_terciles_are_three_hundreds_ranked_by_the_fixed_measure():
    labels = [barn_tercile(i) for i in range(300)]
    assert [labels.count(t) for t in TERCILES] == [100, 100, 100]
    key = {t: [getattr(barn_difficulty(i), TERCILE_MEASURE) for i in range(300) if labels[i] == t]
           for t in TERCILES}  # fmt: skip
    assert min(key["easy"]) >= max(key["middle"]) and min(key["middle"]) >= max(key["hard"])
    assert barn_tercile_group(0) == f"barn-{labels[0]}"


def test_measures_are_finite_and_in_range_on_every_world():
    for i in range(300):
        d = barn_difficulty(i)
        assert 0.3 < d.clearance_min <= d.clearance_mean, i
        assert 0.5 < d.characteristic_dimension < 4.5, i
        assert 1.0 <= d.tortuosity < 1.4, i
