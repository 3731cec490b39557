"""World.distance measures every cylinder at once (BARN has hundreds): the values are those of
the obstacle-by-obstacle minimum, bit for bit, and so is an episode on BARN."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.world import model
from d3dwa_bullet.world.model import World, start_in_collision
from d3dwa_bullet.world.registry import load_world
from tools.bench.bench_barn import distance_one_by_one as one_by_one


def probe_points(world: World, n: int = 3000) -> np.ndarray:
    """Random points over the world's bounds, plus every obstacle centre (inside: negative)."""
    xmin, ymin, xmax, ymax = world.bounds()
    rng = np.random.default_rng(7)
    pts = rng.uniform((xmin, ymin), (xmax, ymax), size=(n, 2))
    return np.vstack((pts, [ob.center for ob in world.obstacles]))


@pytest.mark.parametrize("name", ["BARN-0", "BARN-299", "R2", "TS3", "H2"])
def test_distance_is_bit_identical_to_the_obstacle_by_obstacle_minimum(name):
    world = load_world(name)
    pts = probe_points(world)
    assert np.array_equal(world.distance(pts), one_by_one(world, pts))


@pytest.mark.parametrize("name", ["BARN-57", "TS3"])
@pytest.mark.parametrize("n", [1, 40, 5000])
def test_both_ways_give_the_same_values(name, n, monkeypatch):
    world = load_world(name)
    pts = probe_points(world, n)
    expected = one_by_one(world, pts)
    for broadcast in (0, 10**9):  # obstacle by obstacle, then every cylinder at once
        monkeypatch.setattr(model, "DISTANCE_BROADCAST", broadcast)
        assert np.array_equal(world.distance(pts), expected)


def test_a_world_without_obstacles_is_infinitely_far():
    empty = World("E", "empty", (0.0, 0.0, 0.0), (1.0, 0.0))
    assert np.isinf(empty.distance(np.zeros((3, 2)))).all()
    assert not start_in_collision(empty, (0.0, 0.0, 0.0))


def test_a_barn_episode_is_unchanged(monkeypatch):
    world = load_world("BARN-0")
    fast = run_episode(world, make_controller("dwa3")).summary()
    monkeypatch.setattr(World, "distance", one_by_one)
    slow = run_episode(load_world("BARN-0"), make_controller("dwa3")).summary()
    assert fast == slow
    assert fast["outcome"] == "goal"
