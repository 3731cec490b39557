"""The global plan: costmap costs, shortest path, carrot, blocked replans, no path, goal in an obstacle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.costmap import (
    INFLATION_RADIUS,
    PENALTY,
    RESOLUTION,
    cell_costs,
    free_start,
    occupancy_distance,
    shortest_path,
)
from d3dwa_bullet.planning.global_plan import GlobalPlanner, status_code
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams, global_plan_params
from d3dwa_bullet.planning.recovery import to_body
from d3dwa_bullet.world.grid import clearance_field
from d3dwa_bullet.world.model import Box, World

LETHAL = PlannerParams().admissible_clearance


def wall_points(x: float, y0: float, y1: float, step: float = 0.01) -> np.ndarray:
    """(M, 2) points along a wall x = const from y0 to y1, world frame, m."""
    ys = np.arange(y0, y1 + 1e-9, step)
    return np.column_stack((np.full_like(ys, x), ys))


def scanner(start=(0.0, 0.0, 0.0), goal=(4.0, 0.0), **kw) -> GlobalPlanner:
    return GlobalPlanner(GlobalPlanParams(kind="scan", **kw), PlannerParams(), 0.1, start, goal)


def test_costs_are_lethal_inside_r_plus_m_decay_and_free_beyond_inflation():
    d = np.array([0.0, LETHAL, LETHAL + 0.01, 0.4, INFLATION_RADIUS + 0.01, 5.0])
    c = cell_costs(d, LETHAL)
    assert np.isinf(c[:2]).all()
    assert c[2] == pytest.approx(1 + PENALTY * math.exp(-3.0 * 0.01))
    assert c[2] > c[3] > 1.0
    assert c[4] == c[5] == 1.0


def test_occupancy_distance_in_metres():
    occ = np.zeros((5, 9), dtype=bool)
    occ[2, 0] = True
    d = occupancy_distance(occ, 0.05)
    assert d[2, 4] == pytest.approx(0.2) and d[2, 0] == 0.0
    assert (occupancy_distance(np.zeros((3, 3), dtype=bool), 0.05) > 1e6).all()


def test_shortest_path_goes_round_a_wall_and_none_when_sealed():
    costs = np.ones((20, 20))
    costs[:15, 10] = np.inf
    cells = shortest_path(costs, (0, 0), (0, 19))
    assert cells is not None and tuple(cells[0]) == (0, 0) and tuple(cells[-1]) == (0, 19)
    assert cells[:, 0].max() >= 15  # round the end of the wall
    assert np.isfinite(costs[cells[:, 0], cells[:, 1]]).all()
    costs[:, 10] = np.inf
    assert shortest_path(costs, (0, 0), (0, 19)) is None


def test_free_start_lets_a_pinned_robot_out():
    costs = np.ones((11, 11))
    costs[3:8, 3:8] = np.inf
    out = free_start(costs, (5, 5), 2)
    assert np.isfinite(out[5, 5]) and np.isinf(costs[5, 5])  # a copy, the input is kept
    assert shortest_path(costs, (5, 5), (0, 0)) is None
    assert free_start(np.ones((3, 3)), (1, 1), 1) is not None


def test_map_plan_goes_round_a_known_wall_and_carrot_is_lookahead_along_it():
    wall = Box(center=(2.0, 0.0), size=(0.2, 3.0), yaw=0.0)
    world = World(
        name="w", description="", start=(0.0, 0.0, 0.0), goal=(4.0, 0.0), obstacles=(wall,)
    )
    known = clearance_field(world, RESOLUTION, margin=3.0)
    gp = GlobalPlanner(
        GlobalPlanParams(kind="map", lookahead=1.0),
        PlannerParams(),
        0.1,
        world.start,
        world.goal,
        known,
    )
    carrot = gp.update(0.0, world.start, np.zeros((0, 2)))
    assert gp.status == "ok" and gp.path is not None
    assert abs(gp.path[:, 1]).max() > 1.5 + LETHAL - RESOLUTION  # round the wall's end
    assert (world.distance(gp.path) > LETHAL - RESOLUTION).all()
    assert (
        0.8 < math.hypot(*carrot) <= 1.0 + 1e-9
    )  # 1 m along the (8-connected) path from the start
    _, left = gp.carrot(world.start)
    assert left > 2 * math.hypot(2.0, 1.5 + LETHAL)  # round the end, not straight through


def test_map_needs_a_map():
    with pytest.raises(ConfigError, match="map"):
        GlobalPlanner(GlobalPlanParams(kind="map"), PlannerParams(), 0.1, (0, 0, 0), (4, 0))


@pytest.mark.parametrize(
    "field, value",
    [("kind", "none"), ("kind", "bogus"), ("goal_distance", "x"), ("lookahead", 0.0)],
)
def test_bad_params_refused(field, value):
    with pytest.raises(ConfigError, match=str(value) if field != "lookahead" else "lookahead"):
        GlobalPlanParams(**{field: value})


def test_scan_plan_is_straight_with_nothing_seen_and_the_carrot_is_near_the_goal_at_the_end():
    gp = scanner()
    assert gp.update(0.0, (0.0, 0.0, 0.0), np.zeros((0, 2))) == pytest.approx((2.0, 0.0), abs=1e-9)
    assert gp.carrot((3.5, 0.0, 0.0))[0] == (4.0, 0.0)  # less than the lookahead left: the goal


def test_a_wall_seen_on_the_path_replans_at_once_and_the_new_path_avoids_it():
    gp = scanner()
    pose = (0.0, 0.0, 0.0)
    gp.update(0.0, pose, np.zeros((0, 2)))
    first = gp.path.copy()
    wall = to_body(pose, wall_points(2.0, -1.0, 1.0))
    gp.update(0.1, pose, wall)  # blocked: replans at once (several returns a lattice cell: marked)
    assert gp.replans == 2 and gp.blocked_replans == 1 and gp.status == "ok"
    assert not np.array_equal(gp.path, first)
    assert abs(gp.path[:, 1]).max() > 1.0 + LETHAL - RESOLUTION
    gp.update(0.2, pose, wall)  # the path no longer crosses the wall: no replan until the period
    assert gp.replans == 2


def test_a_single_stray_return_is_not_an_obstacle():
    gp = scanner()
    pose = (0.0, 0.0, 0.0)
    gp.update(0.0, pose, np.zeros((0, 2)))
    gp.update(
        0.1, pose, np.array([[2.0, 0.0]])
    )  # on the path: replans, but one return marks nothing
    assert gp.blocked_replans == 1 and not gp.occupied.any()
    assert abs(gp.path[:, 1]).max() < 1e-9


def test_no_path_falls_back_to_the_goal_and_says_so():
    gp = scanner(goal=(4.0, 0.0))
    ring = np.array(
        [(1.0 * math.cos(a), 1.0 * math.sin(a)) for a in np.linspace(0, 2 * math.pi, 800)]
    )
    for k in range(3):
        carrot = gp.update(1.0 * k, (0.0, 0.0, 0.0), ring)
    assert gp.status == "no_path" and gp.path is None
    assert carrot == (4.0, 0.0)
    assert ("no_path" in [s for _, s in gp.events]) and status_code("no_path") == 1


def test_goal_inside_an_obstacle_falls_back_to_the_goal_and_says_so():
    gp = scanner(goal=(3.0, 0.0))
    pts = to_body((0.0, 0.0, 0.0), wall_points(3.05, -0.5, 0.5))
    for k in range(3):
        carrot = gp.update(1.0 * k, (0.0, 0.0, 0.0), pts)
    assert gp.status == "goal_blocked" and carrot == (3.0, 0.0)


def test_a_pose_off_the_costmap_falls_back_to_the_goal():
    gp = scanner(margin=1.0)
    assert gp.update(0.0, (-50.0, 0.0, 0.0), np.zeros((0, 2))) == (4.0, 0.0)
    assert gp.status == "outside"


def test_path_goal_distance_reads_the_length_left_on_the_carrots_bearing():
    gp = scanner()
    pose = (0.0, 0.0, 0.0)
    carrot = gp.update(0.0, pose, np.zeros((0, 2)))
    assert gp.observed_goal(pose, carrot) == pytest.approx((4.0, 0.0))
    gp2 = scanner(goal_distance="carrot")
    assert gp2.observed_goal(pose, gp2.update(0.0, pose, np.zeros((0, 2)))) == pytest.approx(
        (2.0, 0.0)
    )


def test_global_plan_option_values():
    assert global_plan_params("none") is None
    assert global_plan_params("map").kind == "map"
    with pytest.raises(ConfigError, match="--global-plan 'mapp': choose one of none, scan, map"):
        global_plan_params("mapp")
