"""The global plan of a run that learns its start at its first step (a bag replay, ``d3dwa drive``):
the episode's own GlobalPlanner, and a map in another frame than the estimate's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.planning.global_plan import FirstStepPlan, inverse, make_global_planner, moved
from d3dwa_bullet.planning.global_plan_params import global_plan_params
from d3dwa_bullet.world.model import Box, World

MAP = EpisodeConfig(global_plan=global_plan_params("map"))
SCAN = EpisodeConfig(global_plan=global_plan_params("scan"))


def walled(shift: tuple[float, float] = (0.0, 0.0)) -> World:
    """A wall across the straight line from (0, 0) to (4, 0), everything moved by shift, m."""
    sx, sy = shift
    wall = Box(center=(2.0 + sx, -0.3 + sy), size=(0.2, 2.4), yaw=0.0, height=0.5)
    return World("wall", "", (sx, sy, 0.0), (4.0 + sx, sy), (wall,))


def test_first_step_plan_is_the_episode_plan():
    """Built from the first pose and goal, it gives the carrots make_global_planner's plan gives."""
    world = walled()
    follow, episode = FirstStepPlan(MAP, world), make_global_planner(MAP, world)
    assert episode is not None
    for k, pose in enumerate([(0.0, 0.0, 0.0), (0.3, 0.1, 0.2), (0.6, 0.4, 0.5)]):
        carrot, _ = follow.steer(0.1 * k, pose, np.zeros((0, 2)), world.goal)
        assert carrot == episode.update(0.1 * k, pose, np.zeros((0, 2)))
    assert follow.plan is not None and follow.plan.status == "ok" and carrot != world.goal


def test_map_without_a_map_is_refused_and_none_plans_nothing():
    with pytest.raises(ConfigError, match="--global-plan map needs"):
        FirstStepPlan(MAP)
    none = FirstStepPlan(EpisodeConfig())
    assert none.steer(0.0, (0.0, 0.0, 0.0), np.zeros((0, 2)), (4.0, 0.0)) == (
        (4.0, 0.0),
        (4.0, 0.0),
    )
    assert none.plan is None and FirstStepPlan(SCAN).known is None


def test_a_map_in_another_frame_plans_as_the_same_map_in_the_estimates_frame():
    """A map whose frame puts the estimate's origin at (1.5, -0.5): its carrots, brought back,
    are those of the same map drawn in the estimate's frame (shifts of whole cells)."""
    here = FirstStepPlan(MAP, walled())
    there = FirstStepPlan(MAP, walled((1.5, -0.5)))
    there.frame = (1.5, -0.5, 0.0)
    for k, pose in enumerate([(0.0, 0.0, 0.0), (0.4, 0.2, 0.3), (0.8, 0.5, 0.6)]):
        a, _ = here.steer(0.1 * k, pose, np.zeros((0, 2)), (4.0, 0.0))
        b, _ = there.steer(0.1 * k, pose, np.zeros((0, 2)), (4.0, 0.0))
        np.testing.assert_allclose(b, a, atol=1e-9)
    assert there.plan is not None and there.plan.status == "ok"
    assert abs(there.plan.path[0][0] - 1.5) < 1e-9  # the path runs on the map's frame


def test_moved_and_inverse_round_trip():
    frame = (1.0, -2.0, 2.5)
    p = moved(frame, (0.3, 0.4))
    assert np.allclose(moved(inverse(frame), p), (0.3, 0.4))
    assert np.allclose(moved((0.0, 0.0, math.pi / 2), (1.0, 0.0)), (0.0, 1.0))
