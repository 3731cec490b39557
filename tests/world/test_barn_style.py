"""BARN-style worlds (world/barn_style.py): BARN's recipe, seeded, and refusals of bad seeds."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.tasks import TaskSampler, check_training_world
from d3dwa_bullet.world import barn, barn_style
from d3dwa_bullet.world.barn_path import c_space, crossing_region
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from d3dwa_bullet.world.layout_styles import generate_layout
from d3dwa_bullet.world.registry import load_world

FIRST = barn_style.TRAINING_SEEDS


def test_the_same_seed_gives_the_same_world_and_another_seed_another():
    a, b = barn_style.barn_style_draw(FIRST + 1), barn_style.barn_style_draw(FIRST + 1)
    assert np.array_equal(a.grid, b.grid) and np.array_equal(a.path, b.path)
    assert barn_style.barn_style_world(FIRST + 1) == barn_style.barn_style_world(FIRST + 1)
    assert not np.array_equal(a.grid, barn_style.barn_style_draw(FIRST + 13).grid)


@pytest.mark.parametrize("seed", range(FIRST, FIRST + 12))
def test_a_draw_follows_barns_recipe(seed):
    d = barn_style.barn_style_draw(seed)
    assert (d.fill, d.passes) == barn_style.SETTINGS[seed % 12]
    assert d.grid.shape == (30, 30) and d.grid[0].all() and d.grid[-1].all()
    region = crossing_region(c_space(d.grid))
    assert region is not None  # a 5x5-cell robot crosses
    assert d.path[0, 1] == 0 and d.path[-1, 1] == 29 and np.array_equal(d.path[0], d.path[1])
    assert region[d.path[:, 0], d.path[:, 1]].all()  # every path cell free for the robot


def test_twelve_consecutive_seeds_hold_every_setting_once():
    settings = {barn_style.barn_style_draw(s).passes for s in range(FIRST, FIRST + 3)}
    assert settings == {2, 3, 4}
    assert sorted(barn_style.SETTINGS[s % 12] for s in range(FIRST, FIRST + 12)) == sorted(
        barn_style.SETTINGS
    )


def test_smoothing_counts_rows_beyond_as_walls_and_columns_beyond_as_free():
    grid = np.zeros((30, 30), dtype=bool)
    grid[0] = grid[-1] = True
    grid[1, 5] = True  # 3 filled neighbours (row 0): kept
    grid[20, 10] = True  # no filled neighbour: cleared
    grid[[14, 16, 14, 16], [0, 0, 1, 1]] = True  # 4 neighbours of (15, 0) in the grid
    out = barn_style.smooth(grid)
    assert out[1, 5] and not out[20, 10]
    assert out[0, 0]  # 1 neighbour in the grid + 3 beyond row 0 = 4: kept (free beyond: cleared)
    assert not out[15, 0]  # 4 in the grid, none beyond the column: not filled (5 needed)
    grid[15, 1] = True
    assert barn_style.smooth(grid)[15, 0]  # 5: filled


def test_the_world_is_barns_task_on_the_grid_in_its_own_group():
    d = barn_style.barn_style_draw(FIRST)
    world = barn_style.barn_style_world(FIRST)
    assert world.name == f"BARN-style-s{FIRST}" and world.group == "barn-style"
    assert world.start == barn.START and world.goal == barn.GOAL
    assert world.time_limit == barn.TIME_LIMIT
    assert world.obstacles == barn.barn_cylinders(d.grid)
    assert world.reference_length == pytest.approx(barn.path_length(d.path))
    assert "not one of BARN's" in world.description
    assert load_world(world.name.lower()) == world


@pytest.mark.parametrize(
    ("count", "seed", "message"),
    [
        (0, FIRST, "--count must be a positive integer"),
        (-3, FIRST, "got -3"),
        ("7", FIRST, "got '7'"),
        (2.0, FIRST, "got 2.0"),
        (True, FIRST, "got True"),
        (5, FIRST - 1, f"--seed {FIRST - 1}: BARN-style seeds below {FIRST}"),
        (5, 0, "--seed 0"),
        (5, -1, "got -1"),
        (2, barn_style.MAX_SEED, "got 9223372036854775808"),
    ],
)
def test_bad_count_or_training_seed_is_refused_naming_the_value(count, seed, message):
    with pytest.raises(ConfigError, match=message):
        barn_style.barn_style_names(count, seed)


def test_names_run_from_the_seed_and_the_bound_is_the_r_style_one():
    assert barn_style.TRAINING_SEEDS == UNSEEN_LAYOUT_SEED_BASE == 2**31
    assert barn_style.barn_style_names(2, FIRST + 5) == [
        f"BARN-style-s{FIRST + 5}",
        f"BARN-style-s{FIRST + 6}",
    ]


def test_training_draws_barn_style_below_2_31_and_refuses_evaluation_worlds():
    sampler = TaskSampler(worlds=(), generators=("BARN-style",), noise="none")
    task = sampler.draw(7, {})
    seed = barn_style.barn_style_seed(task.world.name)
    assert task.task == "BARN-style" and seed is not None and seed < FIRST
    assert task.world == sampler.draw(7, {}).world  # the same episode seed, the same world
    assert generate_layout("barn-style", 3) == barn_style.barn_style_world(3)
    check_training_world(barn_style.barn_style_world(3))  # a training seed: fine
    with pytest.raises(ConfigError, match="evaluation seed"):
        check_training_world(barn_style.barn_style_world(FIRST))
