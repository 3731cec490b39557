"""The carrot rules (planning/carrot.py): along cuts a corner through a lethal cell, sight does not;
on a straight path, or with nothing lethal, both give the same carrot."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.carrot import carrot_point, in_sight, point_at
from d3dwa_bullet.planning.costmap import RESOLUTION
from d3dwa_bullet.planning.global_plan import GlobalPlanner
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams, global_plan_params, plan_name
from d3dwa_bullet.world.grid import clearance_field
from d3dwa_bullet.world.model import Box, World

ORIGIN = (-1.0, -1.0)
IGNORE = 0.25


def grid_xy(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(X, Y) m of each cell centre of a (ny, nx) grid at ORIGIN and RESOLUTION."""
    ys, xs = np.indices(shape)
    return ORIGIN[0] + xs * RESOLUTION, ORIGIN[1] + ys * RESOLUTION


def corner() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lethal (80, 80) bool, path (K, 2) m, arc (K,) m): a path east along y = 0 to x = 1.5,
    then north, round a lethal block x in [0.5, 1.35], y in [0.15, 2.0] inside its corner."""
    lethal = np.zeros((80, 80), dtype=bool)
    x, y = grid_xy(lethal.shape)
    lethal[(x >= 0.5) & (x <= 1.35) & (y >= 0.15) & (y <= 2.0)] = True
    east = [(x, 0.0) for x in np.arange(0.0, 1.5 + 1e-9, RESOLUTION)]
    north = [(1.5, y) for y in np.arange(RESOLUTION, 2.0, RESOLUTION)]
    path = np.array(east + north)
    return lethal, path, arc_of(path)


def arc_of(path: np.ndarray) -> np.ndarray:
    return np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))))


def test_along_cuts_the_corner_through_a_lethal_cell_and_sight_does_not():
    lethal, path, arc = corner()
    pose = (0.0, 0.0, 0.0)
    along, left = carrot_point("along", path, arc, pose, 2.0, lethal, ORIGIN, RESOLUTION, IGNORE)
    sight, left2 = carrot_point("sight", path, arc, pose, 2.0, lethal, ORIGIN, RESOLUTION, IGNORE)
    assert along == pytest.approx((1.5, 0.5)) and left == left2 == pytest.approx(arc[-1])
    assert not in_sight(lethal, ORIGIN, RESOLUTION, pose, along, IGNORE)
    assert in_sight(lethal, ORIGIN, RESOLUTION, pose, sight, IGNORE)
    assert any(np.allclose(sight, p) for p in path)  # a point of the path
    k = int(np.flatnonzero(np.all(np.isclose(path, sight), axis=1))[0])
    assert 1.5 <= arc[k] < 2.0  # past the turn's start, short of the lookahead
    assert not in_sight(
        lethal, ORIGIN, RESOLUTION, pose, path[k + 1], IGNORE
    )  # the first out of sight


def test_past_the_corner_both_rules_agree():
    lethal, path, arc = corner()
    pose = (1.5, 0.1, 0.0)  # round the turn: the rest of the path runs straight north
    a = carrot_point("along", path, arc, pose, 1.0, lethal, ORIGIN, RESOLUTION, IGNORE)[0]
    s = carrot_point("sight", path, arc, pose, 1.0, lethal, ORIGIN, RESOLUTION, IGNORE)[0]
    assert a == pytest.approx(s) and a == pytest.approx((1.5, 1.1))


@pytest.mark.parametrize("lookahead", [0.3, 1.0, 2.0, 5.0])
def test_straight_path_or_nothing_lethal_gives_the_along_carrot(lookahead):
    path = np.column_stack((np.arange(0.0, 3.0 + 1e-9, RESOLUTION), np.zeros(61)))
    arc = arc_of(path)
    lethal = np.zeros((80, 100), dtype=bool)
    x, y = grid_xy(lethal.shape)
    lethal[np.abs(y) > 0.5] = True  # a corridor: walls beside the path, none across it
    pose = (0.02, 0.01, 0.0)
    along = carrot_point("along", path, arc, pose, lookahead)[0]
    assert along == pytest.approx(point_at(path, arc, lookahead))
    sight = carrot_point("sight", path, arc, pose, lookahead, lethal, ORIGIN, RESOLUTION, IGNORE)[0]
    assert sight == pytest.approx(along)
    lethal_corner, cpath, carc = corner()
    assert carrot_point("sight", cpath, carc, pose, lookahead)[0] == pytest.approx(
        carrot_point("along", cpath, carc, pose, lookahead)[0]
    )  # no costmap given: nothing is in the way


def test_cells_near_the_robot_are_not_checked_and_a_blocked_first_point_is_the_carrot():
    path = np.column_stack((np.arange(0.0, 2.0 + 1e-9, RESOLUTION), np.zeros(41)))
    arc = arc_of(path)
    lethal = np.zeros((60, 80), dtype=bool)
    lethal[20, 22] = True  # the cell at (0.1, 0), on the path beside the robot
    pose = (0.0, 0.0, 0.0)
    s = carrot_point("sight", path, arc, pose, 1.0, lethal, ORIGIN, RESOLUTION, IGNORE)[0]
    assert s == pytest.approx((1.0, 0.0))  # within IGNORE of the pose: not in the way
    s0 = carrot_point("sight", path, arc, pose, 1.0, lethal, ORIGIN, RESOLUTION, 0.0)[0]
    assert s0 == pytest.approx(path[1])  # nothing in sight: the first point ahead


def test_a_map_plan_round_a_wall_keeps_the_sight_carrot_off_lethal_cells():
    wall = Box(center=(2.0, 0.0), size=(0.2, 3.0), yaw=0.0)
    world = World(
        name="w", description="", start=(0.0, 0.0, 0.0), goal=(4.0, 0.0), obstacles=(wall,)
    )
    known = clearance_field(world, RESOLUTION, margin=3.0)
    lethal = known.values <= PlannerParams().admissible_clearance
    seen = {}
    for rule in ("along", "sight"):
        params = GlobalPlanParams(kind="map", carrot=rule)
        gp = GlobalPlanner(params, PlannerParams(), 0.1, world.start, world.goal, known)
        gp.update(0.0, world.start, np.zeros((0, 2)))
        assert gp.path is not None and gp.path[:, 1].max() > 1.5  # round the wall's end
        poses = [(float(x), float(y), 0.0) for x, y in gp.path[::3]]
        carrots = [np.array(gp.carrot(pose)[0]) for pose in poses]
        seen[rule] = [
            in_sight(lethal, known.origin, RESOLUTION, p, c, IGNORE)
            for p, c in zip(poses, carrots, strict=True)
        ]
    assert all(seen["sight"])
    assert not all(seen["along"])  # past the wall's end the along carrot lies across it


def test_carrot_option_values_and_names():
    assert GlobalPlanParams().carrot == "along"
    assert global_plan_params("scan", "sight").carrot == "sight"
    assert plan_name(global_plan_params("scan")) == "scan"
    assert plan_name(global_plan_params("map", "sight")) == "map+sight"
    assert plan_name(None) == "none"
    with pytest.raises(ConfigError, match="--carrot 'ahead': choose one of along, sight"):
        global_plan_params("scan", "ahead")
    with pytest.raises(ConfigError, match="--carrot sight needs --global-plan scan or map"):
        global_plan_params("none", "sight")
    with pytest.raises(ConfigError, match="--carrot 'x'"):
        GlobalPlanParams(carrot="x")
