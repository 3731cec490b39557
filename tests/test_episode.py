"""The episode loop: outcomes, logs, determinism, and no contact in the shipped worlds."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, run_episode
from d3dwa_bullet.method_specs import FIXED
from d3dwa_bullet.world.model import Cylinder, World
from d3dwa_bullet.world.registry import load_world, world_paths


def test_fixed_baseline_goes_around_a_post_to_the_goal(post_world):
    res = run_episode(post_world, make_controller("dwa3"))
    assert res.outcome == "goal"
    assert 2.4 < res.tl_m < 3.5 and res.min_clearance_m > 0.0
    assert res.steps == len(res.log["t"]) and res.observations.shape == (res.steps, 12)
    assert set(res.log["tau"]) == {4.0} and (res.log["action"] == -1).all()
    final = np.hypot(res.log["true_x"][-1] - 2.5, res.log["true_y"][-1])
    assert final <= 0.10


def test_time_limit_gives_a_timeout(post_world):
    res = run_episode(post_world.with_task(time_limit=1.0), make_controller("dwa1"))
    assert res.outcome == "timeout" and res.steps == 10 and res.time_s == pytest.approx(1.0)


def test_lidar_below_collision_threshold_ends_the_episode():
    # A thin post 0.094 m in front of the lidar, clear of the body: only the lidar sees it.
    world = World(
        "near", "post at the lidar", (0, 0, 0), (-1.0, 0.0), (Cylinder((0.30, 0.0), 0.05),)
    )
    with Episode(world) as ep:
        ep.observe()
        assert ep.outcome == "collision"
        assert ep.obstacle_distance == pytest.approx(0.30 - 0.05 - 0.156, abs=2e-3)


def test_acting_after_the_end_is_refused():
    world = World(
        "near", "post at the lidar", (0, 0, 0), (-1.0, 0.0), (Cylinder((0.30, 0.0), 0.05),)
    )
    with Episode(world) as ep:
        ep.observe()
        with pytest.raises(RuntimeError, match="over"):
            ep.act(-1, FIXED["dwa1"])


def test_same_seed_gives_the_same_episode(post_world):
    a = run_episode(post_world, make_controller("dwa2"), seed=3)
    b = run_episode(post_world, make_controller("dwa2"), seed=3)
    assert a.summary() == b.summary()
    for k in a.log:
        assert np.array_equal(a.log[k], b.log[k])


def _no_contact_run(name: str, method: str, seconds: float) -> str:
    world = load_world(name).with_task(time_limit=seconds)
    contacts = []

    def check(ep, *_):
        contacts.append(ep.sim.in_contact())

    res = run_episode(world, make_controller(method), on_step=check)
    assert not any(contacts), f"{name} {method}: Bullet contact during the episode"
    return res.outcome


@pytest.mark.parametrize("name", list(world_paths()))
def test_planner_never_drives_into_contact_in_shipped_worlds(name):
    assert _no_contact_run(name, "dwa3", 12.0) != "collision"


@pytest.mark.slow
@pytest.mark.parametrize("method", list(FIXED))
@pytest.mark.parametrize("name", list(world_paths()))
def test_fixed_baselines_never_collide_in_full_episodes(name, method):
    assert _no_contact_run(name, method, 60.0) != "collision"
