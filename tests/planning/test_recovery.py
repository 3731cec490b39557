"""The recovery layer: Nav2's progress checker, the behaviours, and what keeps them safe."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import PlannerParams, RecoveryParams, recovery_params
from d3dwa_bullet.planning.recovery import (
    ProgressChecker,
    Recovery,
    ScanMemory,
    motion_clear,
    to_body,
    to_world,
)

DT = 0.1
FOV = math.radians(240.0)
LIDAR_X = 0.156
LEFT = (0.0, 1.0)
"""A goal on the robot's left, in base_link."""


def corridor(half_width: float, x0: float = -0.5, x1: float = 0.6) -> np.ndarray:
    """Points of two walls along x at y = +-half_width, 1 cm apart, in the frame they are given."""
    xs = np.arange(x0, x1, 0.01)
    return np.concatenate(
        [np.column_stack((xs, np.full_like(xs, s * half_width))) for s in (1, -1)]
    )


def in_view(points_world: np.ndarray, pose) -> np.ndarray:
    """What a 240 deg lidar at pose sees of points_world, in base_link (no occlusion)."""
    body = to_body(pose, points_world)
    bearing = np.arctan2(body[:, 1], body[:, 0] - LIDAR_X)
    return body[np.abs(bearing) <= 0.5 * FOV]


def layer(**kw) -> Recovery:
    return Recovery(RecoveryParams(**kw), PlannerParams(), DT, LIDAR_X, FOV)


def stand(rec: Recovery, pose, world_points, t0: float, seconds: float, goal=LEFT):
    """Feed the layer a robot standing at pose for `seconds`; the first command it returns
    (and its time), or (None, t_end)."""
    t = t0
    while t < t0 + seconds:
        cmd = rec.command(t, pose, in_view(world_points, pose), goal)
        if cmd is not None:
            return cmd, t
        t = round(t + DT, 9)
    return None, t


def stuck_in_the_open(rec: Recovery):
    """Arrive from 1 m back (so the space behind was seen), then stand past the progress
    window with nothing in view: the layer's first command and its time."""
    rec.command(0.0, (-1.0, 0.0, 0.0), np.zeros((0, 2)), LEFT)
    return stand(rec, (0.0, 0.0, 0.0), np.zeros((0, 2)), DT, 11.0)


def test_progress_checker_has_nav2_semantics():
    checker = ProgressChecker(radius=0.5, window=10.0)
    assert not checker.stuck(0.0, (0.0, 0.0, 0.0))
    assert not checker.stuck(10.0, (0.4, 0.0, 3.0))  # turning and creeping inside the circle
    assert checker.stuck(10.1, (0.45, 0.0, 0.0))  # 10 s passed without leaving it
    checker.reset(10.1, (0.45, 0.0, 0.0))
    assert not checker.stuck(19.0, (0.96, 0.0, 0.0))  # left the circle: new baseline, new clock
    assert not checker.stuck(29.0, (0.96, 0.0, 0.0))
    assert checker.stuck(29.1, (0.96, 0.0, 0.0))


def test_nothing_happens_while_the_robot_progresses_or_before_the_window():
    rec = layer()
    cmd, t = stand(rec, (0.0, 0.0, 0.0), np.zeros((0, 2)), 0.0, 10.0)
    assert cmd is None and rec.started == 0
    for k in range(200):  # moving at 0.1 m/s: never stuck
        assert rec.command(10.0 + k * DT, (0.01 * k, 0.0, 0.0), np.zeros((0, 2)), LEFT) is None


def test_a_stuck_robot_in_the_open_spins_toward_the_goal_side():
    rec = layer()
    cmd, t = stuck_in_the_open(rec)
    assert cmd is not None and cmd.behaviour == "spin" and cmd.w > 0 and cmd.v == 0.0
    assert 10.0 < t <= 10.2 and rec.started == 1 and rec.active == "spin"
    cmd, _ = stand(rec, (0.0, 0.0, 0.0), np.zeros((0, 2)), t + DT, 1.0, goal=(0.0, -1.0))
    assert cmd is not None and cmd.w > 0  # a spin keeps its sense once started


def test_a_spin_runs_its_angle_and_then_hands_back():
    rec = layer(spin_angle=1.0)
    cmd, t = stuck_in_the_open(rec)
    yaw, steps = 0.0, 0
    while cmd is not None:
        yaw += cmd.w * DT
        steps += 1
        t = round(t + DT, 9)
        cmd = rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT)
    assert yaw == pytest.approx(1.0, abs=0.05) and 10 <= steps <= 12
    assert rec.active is None
    # handing back restarts the progress clock: no new recovery for another window
    cmd, t2 = stand(rec, (0.0, 0.0, yaw), np.zeros((0, 2)), t + DT, 9.5)
    assert cmd is None


def test_in_a_narrow_corridor_the_spin_is_refused_and_the_robot_backs_up():
    walls = corridor(0.25)  # the body's circles reach 0.15 m: 0.25 m walls leave 0.25 > r + m
    rec = layer()
    for k in range(10):  # drove in along the corridor: it saw the corridor behind it
        rec.command(
            k * DT, (-1.0 + 0.1 * k, 0.0, 0.0), in_view(walls, (-1.0 + 0.1 * k, 0, 0)), LEFT
        )
    cmd, _ = stand(rec, (0.0, 0.0, 0.0), walls, 1.0, 12.0)
    assert cmd is not None and cmd.behaviour == "back_up"
    assert cmd.v == pytest.approx(-0.15) and cmd.w == 0.0


def test_backing_up_into_what_was_never_seen_is_refused():
    walls = corridor(0.25)
    rec = layer()  # it has only ever looked forward from where it stands
    cmd, _ = stand(rec, (0.0, 0.0, 0.0), walls, 0.0, 25.0)
    assert cmd is None and rec.started == 0 and rec.refused == 2


def test_backing_up_toward_a_remembered_wall_is_refused():
    walls = corridor(0.25)
    behind = np.column_stack((np.full(41, -0.45), np.linspace(-0.2, 0.2, 41)))
    seen_before = np.concatenate((walls, behind))
    rec = layer()
    for k in range(5):  # it looked back at that wall for half a second, then turned round
        rec.command(k * DT, (0.3, 0.0, math.pi), in_view(seen_before, (0.3, 0.0, math.pi)), LEFT)
        rec.command(k * DT, (-1.0, 0.0, 0.0), in_view(walls, (-1.0, 0.0, 0.0)), LEFT)
    # now facing +x at the origin: the wall 0.45 m behind it is out of the lidar's view
    assert len(in_view(behind, (0.0, 0.0, 0.0))) == 0
    cmd, t = stand(rec, (0.0, 0.0, 0.0), walls, 1.0, 12.0)
    assert cmd is not None and cmd.behaviour == "back_up"  # the first 0.15 m are clear
    x = 0.0
    while cmd is not None:  # back up as commanded until the layer stops
        x += cmd.v * DT
        t = round(t + DT, 9)
        cmd = rec.command(t, (x, 0.0, 0.0), in_view(walls, (x, 0.0, 0.0)), LEFT)
    # it stops while the next second of motion (0.15 m) is still clear of r + m, so well
    # before the full 0.30 m: the rear circle never came within r + m of the wall
    assert -0.3 < x < 0.0
    assert (x - 0.0855) - (-0.45) > 0.2


def test_one_spurious_return_is_forgotten_a_surface_is_not():
    memory = ScanMemory(10)
    memory.add((0.0, 0.0, 0.0), np.array([[-0.5, 0.0]]))
    points, poses = memory.merged((0.0, 0.0, 0.0), 2.0)
    assert len(points) == 0 and len(poses) == 1
    memory.add((0.0, 0.0, 0.0), np.array([[-0.5, 0.005]]))  # hit again, same 2 cm cell
    points, _ = memory.merged((0.0, 0.0, 0.0), 2.0)
    assert points.tolist() == [[-0.5, 0.0]]
    points, _ = memory.merged((3.0, 0.0, 0.0), 2.0)  # out of reach of the robot
    assert len(points) == 0


def test_memory_keeps_only_its_window():
    memory = ScanMemory(3)
    for k in range(5):
        memory.add((float(k), 0.0, 0.0), np.zeros((0, 2)))
    _, poses = memory.merged((0.0, 0.0, 0.0), 1.0)
    assert poses[:, 0].tolist() == [2.0, 3.0, 4.0]


def test_a_behaviour_stops_where_its_motion_stops_being_admissible():
    walls = corridor(0.25)
    rec = layer()
    for k in range(10):
        rec.command(
            k * DT, (-1.0 + 0.1 * k, 0.0, 0.0), in_view(walls, (-1.0 + 0.1 * k, 0, 0)), LEFT
        )
    cmd, t = stand(rec, (0.0, 0.0, 0.0), walls, 1.0, 12.0)
    assert cmd is not None and cmd.behaviour == "back_up"
    # something steps in right behind the robot: it is seen (the lidar sweeps it, say) now
    intruder = np.column_stack((np.full(21, -0.33), np.linspace(-0.1, 0.1, 21)))
    everything = np.concatenate((in_view(walls, (0.0, 0.0, 0.0)), intruder))
    assert rec.command(t + DT, (-0.01, 0.0, 0.0), everything, LEFT) is None
    assert rec.active is None


def test_the_layer_gives_up_after_max_recoveries():
    rec = layer(max_recoveries=1, spin_angle=0.2)
    cmd, t = stuck_in_the_open(rec)
    assert cmd is not None
    yaw = 0.0
    while cmd is not None:
        yaw += cmd.w * DT
        t = round(t + DT, 9)
        cmd = rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT)
    cmd, _ = stand(rec, (0.0, 0.0, yaw), np.zeros((0, 2)), t + DT, 40.0)
    assert cmd is None and rec.started == 1


def test_motion_clear_matches_the_planner_margin():
    planner = PlannerParams()
    seen_all = np.array([[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    # a post 0.45 m behind base_link: the rear circle (centre -0.0855) ends 0.3 m back at
    # -0.3855, 0.0645 m from the post: not admissible; 0.1 m back leaves 0.2645 m: admissible
    post = np.array([[-0.45, 0.0]])
    assert not motion_clear("back_up", 0.3, 1.0, post, seen_all, planner, LIDAR_X, FOV)
    assert motion_clear("back_up", 0.1, 1.0, post, seen_all, planner, LIDAR_X, FOV)


def test_a_robot_already_inside_the_margin_may_move_away_but_not_closer():
    planner = PlannerParams()
    seen_all = np.array([[-1.0, 0.0, 0.0]])
    ahead = np.array([[0.1725 + 0.18, 0.0]])  # 0.18 m in front of the front circle: < r + m
    assert motion_clear("back_up", 0.1, 1.0, ahead, seen_all, planner, LIDAR_X, FOV)
    behind = np.array([[-0.0855 - 0.18, 0.0]])
    assert not motion_clear("back_up", 0.1, 1.0, behind, seen_all, planner, LIDAR_X, FOV)


def test_frames_round_trip():
    pose = (1.0, -2.0, 0.7)
    pts = np.array([[0.3, 0.1], [-1.0, 2.0]])
    assert np.allclose(to_body(pose, to_world(pose, pts)), pts)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"radius": 0.0}, "radius must be a number > 0"),
        ({"window": -1.0}, "window must be a number > 0"),
        ({"radius": float("nan")}, "radius"),
        ({"sequence": ("spin", "wait")}, "sequence"),
        ({"sequence": ()}, "sequence"),
        ({"kind": "none"}, "unknown recovery"),
        ({"max_recoveries": -1}, "max_recoveries"),
    ],
)
def test_bad_recovery_params_are_refused(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        RecoveryParams(**kwargs)


def test_recovery_names():
    assert recovery_params("none") is None
    assert recovery_params("nav2", radius=0.3).radius == 0.3
    with pytest.raises(ConfigError, match="unknown recovery 'bogus'"):
        recovery_params("bogus")
    with pytest.raises(ConfigError, match="shorter than one control step"):
        Recovery(RecoveryParams(window=0.05), PlannerParams(), DT, LIDAR_X, FOV)


def test_a_behaviour_hands_back_only_at_rest():
    # Handed back turning, the planner's window (+-0.3 rad/s a step) holds no stop: the layer
    # commands a stop until the estimate is at rest, at most BRAKE_LIMIT, then hands back.
    rec = layer(spin_angle=0.3)
    cmd, t = stuck_in_the_open(rec)
    yaw = 0.0
    while cmd is not None and cmd.w != 0.0:
        yaw += cmd.w * DT
        t = round(t + DT, 9)
        cmd = rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT, (0.0, 1.0))
    assert cmd is not None and (cmd.v, cmd.w) == (0.0, 0.0) and cmd.behaviour == "spin"
    stops = 1
    for w in (0.7, 0.4):  # still turning: keeps stopping
        t = round(t + DT, 9)
        cmd = rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT, (0.0, w))
        assert cmd == (0.0, 0.0, "spin")
        stops += 1
    t = round(t + DT, 9)
    assert rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT, (0.0, 0.05)) is None
    assert rec.active is None and stops == 3
    # an estimate that never settles (a biased gyro) hands back after BRAKE_LIMIT anyway
    rec = layer(spin_angle=0.3)
    cmd, t = stuck_in_the_open(rec)
    yaw, n = 0.0, 0
    while cmd is not None:
        yaw += cmd.w * DT
        t = round(t + DT, 9)
        cmd = rec.command(t, (0.0, 0.0, yaw), np.zeros((0, 2)), LEFT, (0.0, 0.5))
        n += cmd is not None and cmd.w == 0.0
    assert n == 10  # 1 s of stop commands at 10 Hz
