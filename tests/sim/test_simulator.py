"""The PyBullet shell: URDF, driving, limits, lidar geometry, contacts, several clients."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import SimParams
from d3dwa_bullet.resources import urdf_path
from d3dwa_bullet.robot import BODY_CENTER, IMU_MOUNT, LIDAR_MOUNT, TRACK
from d3dwa_bullet.sim import simulator
from d3dwa_bullet.sim.lidar import LidarParams
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.model import Box, World


def drive(sim: Simulator, v: float, w: float, seconds: float) -> None:
    for _ in range(int(round(seconds * sim.sim.control_hz))):
        sim.step(v, w)


@pytest.mark.parametrize(("physics", "control"), [(240, 7), (100, 30), (0, 10), (240, 0)])
def test_non_divisible_or_bad_rates_raise(physics, control):
    with pytest.raises(ConfigError, match="physics_hz|rates"):
        SimParams(physics_hz=physics, control_hz=control)


def test_urdf_has_the_vendor_geometry():
    c = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(urdf_path()), physicsClientId=c)
        joints = {
            p.getJointInfo(robot, j, physicsClientId=c)[1].decode(): p.getJointInfo(
                robot, j, physicsClientId=c
            )
            for j in range(p.getNumJoints(robot, physicsClientId=c))
        }
        com = np.array(p.getDynamicsInfo(robot, -1, physicsClientId=c)[3])
        assert com == pytest.approx(BODY_CENTER)
        assert p.getDynamicsInfo(robot, -1, physicsClientId=c)[0] == pytest.approx(6.4)

        def origin(name):  # PyBullet gives joint frames relative to the parent's inertial frame
            return np.asarray(joints[name][14]) + com

        assert joints["left_wheel_joint"][2] == p.JOINT_REVOLUTE
        assert origin("left_wheel_joint") == pytest.approx((0, TRACK / 2, 0), abs=1e-9)
        assert origin("right_wheel_joint") == pytest.approx((0, -TRACK / 2, 0), abs=1e-9)
        assert origin("lidar_link_joint") == pytest.approx(LIDAR_MOUNT, abs=1e-9)
        assert origin("imu_link_joint") == pytest.approx(IMU_MOUNT, abs=1e-9)
    finally:
        p.disconnect(c)


def test_start_pose_is_reported_at_base_link_not_centre_of_mass(open_world):
    w = open_world.with_task(start=(0.5, -0.3, 1.0))
    with Simulator(w) as sim:
        assert sim.true_pose() == pytest.approx((0.5, -0.3, 1.0), abs=1e-6)


def test_driving_straight_follows_command_and_acceleration_limit(open_world):
    with Simulator(open_world) as sim:
        sim.step(0.4, 0.0)
        assert sim.command == pytest.approx((0.2, 0.0))  # a_max * dt = 0.2 m/s per period
        drive(sim, 0.4, 0.0, 2.0)
        x, y, yaw = sim.true_pose()
        v, w = sim.true_velocity()
    assert v == pytest.approx(0.4, abs=0.02) and abs(w) < 0.02
    assert 0.70 < x < 0.86 and abs(y) < 0.02 and abs(yaw) < 0.02  # 2.1 s, ramp then 0.4 m/s


def test_turning_in_place_reaches_commanded_rate(open_world):
    with Simulator(open_world) as sim:
        drive(sim, 0.0, 1.0, 1.0)
        assert sim.command == pytest.approx((0.0, 1.0))
        # The rate over a whole second: Bullet's instantaneous wheel-contact velocity
        # jitters by a few per cent from one 0.1 s period to the next.
        yaw0 = sim.true_pose()[2]
        drive(sim, 0.0, 1.0, 1.0)
        x, y, yaw1 = sim.true_pose()
    assert math.remainder(yaw1 - yaw0, math.tau) == pytest.approx(1.0, abs=0.03)
    assert math.hypot(x, y) < 0.02


def test_commands_are_clipped_to_velocity_limits(open_world):
    with Simulator(open_world) as sim:
        drive(sim, 5.0, -9.0, 1.5)
        assert sim.command == pytest.approx((0.4, -2.0))
        drive(sim, -1.0, 0.0, 0.5)
        # reverse (only the recovery layer's back-up asks for it) is clipped at -v_max
        assert sim.command[0] == pytest.approx(-0.4)


def test_lidar_range_to_a_wall_ahead_is_exact(wall_world):
    with Simulator(wall_world) as sim:
        scan, true = sim.sense()
    ahead = len(true) // 2
    assert scan.angles[ahead] == pytest.approx(0.0, abs=1e-6)
    assert true[ahead] == pytest.approx(1.95 - LIDAR_MOUNT[0], abs=1e-6)
    # Beams at +-120 deg see nothing (the wall is ahead only): +inf, the REP-117 "no return".
    assert np.isinf(true[0]) and np.isinf(true[-1])
    assert len(true) == LidarParams().beams == 481


def test_lidar_follows_the_robot_pose(wall_world):
    world = wall_world.with_task(start=(0.5, 0.0, 0.0))
    with Simulator(world) as sim:
        _, true = sim.sense()
    assert true[len(true) // 2] == pytest.approx(1.95 - LIDAR_MOUNT[0] - 0.5, abs=1e-6)


def test_contact_is_reported_when_driving_into_a_wall():
    world = World(
        "w", "wall close ahead", (0.0, 0.0, 0.0), (-1.0, 0.0), (Box((0.6, 0.0), (0.1, 2.0)),)
    )
    with Simulator(world) as sim:
        touched = False
        for _ in range(40):
            sim.step(0.4, 0.0)
            if sim.in_contact():
                touched = True
                break
    assert touched


def test_two_simulators_in_one_process_are_independent(open_world):
    with Simulator(open_world) as a, Simulator(open_world.with_task(start=(1.0, 1.0, 0.0))) as b:
        drive(a, 0.4, 0.0, 1.0)
        assert b.true_pose() == pytest.approx((1.0, 1.0, 0.0), abs=1e-6)
        assert a.client != b.client


def test_same_commands_give_bit_identical_trajectories(post_world):
    poses = []
    for _ in range(2):
        with Simulator(post_world) as sim:
            drive(sim, 0.3, 0.4, 2.0)
            poses.append(sim.true_pose())
    assert poses[0] == poses[1]


def test_a_world_hands_pybullet_the_same_mesh_lists_every_episode(monkeypatch):
    # PyBullet never releases its references to the items of a mesh's vertex and index lists,
    # so lists built anew each episode grew a worker without bound; the same objects do not.
    handed: list[tuple[list, list]] = []  # the objects themselves: no id is reused
    create = simulator.p.createCollisionShape

    def spy(*args, **kwargs):
        if "vertices" in kwargs:
            handed.append((kwargs["vertices"], kwargs["indices"]))
        return create(*args, **kwargs)

    monkeypatch.setattr(simulator.p, "createCollisionShape", spy)
    obstacles = (Box((1.0, 0.0), (0.2, 0.2)), Box((-1.0, 0.5), (0.1, 0.3), height=0.1))
    world = World("mesh", "", (0.0, 0.0, 0.0), (2.0, 0.0), obstacles)
    other = World("other", "", (0.0, 0.0, 0.0), (2.0, 0.0), obstacles[:1])
    for w in (world, world, other):
        with Simulator(w):
            pass
    assert len(handed) == 3
    assert handed[0][0] is handed[1][0] and handed[0][1] is handed[1][1]
    assert handed[2][0] is not handed[0][0] and len(handed[2][0]) < len(handed[0][0])
    vertices, sides, drawn = simulator.obstacle_mesh(obstacles)
    assert len(vertices) % 2 == 0 and len(sides) % 3 == 0 and drawn[: len(sides)] == sides
    assert len(drawn) > len(sides)  # the tall box's caps are drawn only, the low one's collide
