"""BARN's path search (world/barn_path.py) against BARN's own 300 path files."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.world.barn import BARN_WORLDS, read_world_file, world_file
from d3dwa_bullet.world.barn_path import barn_search, c_space, crossing_region


@pytest.mark.parametrize("index", range(0, BARN_WORLDS, 3))
def test_search_gives_back_barns_path_file(index):
    grid, path = read_world_file(world_file(index))
    blocked = c_space(grid)
    region = crossing_region(blocked)
    assert region is not None and region[tuple(path[0])] and region[tuple(path[-1])]
    got = barn_search(blocked, tuple(path[0]), tuple(path[-1]))
    assert got is not None and np.array_equal(got, path)  # cell for cell, the start twice


def test_c_space_blocks_a_5x5_robot():
    grid = np.zeros((30, 30), dtype=bool)
    grid[10, 10] = True
    blocked = c_space(grid)
    assert blocked[8:13, 8:13].all() and blocked.sum() == 25


def test_a_wall_across_leaves_no_crossing():
    grid = np.zeros((30, 30), dtype=bool)
    grid[0] = grid[-1] = True
    assert crossing_region(c_space(grid)) is not None
    grid[:, 15] = True  # a full wall between the two columns
    assert crossing_region(c_space(grid)) is None


def test_search_turns_at_most_45_degrees_and_refuses_a_blocked_end():
    blocked = np.zeros((9, 9), dtype=bool)
    path = barn_search(blocked, (4, 0), (4, 8))
    assert path is not None and np.array_equal(path[0], path[1])
    moves = np.diff(path[1:], axis=0)
    assert (np.abs(moves) <= 1).all()
    headings = np.arctan2(moves[:, 0], moves[:, 1])
    turns = np.abs(np.angle(np.exp(1j * np.diff(headings))))
    assert (turns <= np.pi / 4 + 1e-9).all()
    blocked[4, 8] = True
    with pytest.raises(ValueError, match="blocked"):
        barn_search(blocked, (4, 0), (4, 8))
