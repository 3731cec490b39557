"""The lidar's ray batch on one thread (a pool worker) casts the same ranges as on every core,
and a pool worker sets one thread (docs/design/episode-cost.md)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest

from d3dwa_bullet.backends import one_core_per_worker
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.sim.lidar_params import ray_threads, set_ray_threads
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.barn import barn_world


@pytest.fixture
def restore_threads():
    before = ray_threads()
    yield
    set_ray_threads(before)


def test_one_thread_casts_the_same_ranges(restore_threads):
    with Simulator(barn_world(150)) as sim:
        x, y, yaw = sim.world.start
        casts = {}
        for threads in (0, 1, 2):
            set_ray_threads(threads)
            ranges = []
            for k in range(6):  # a few poses along the start's heading, turning
                pose = [x + 0.3 * k * math.cos(yaw), y + 0.3 * k * math.sin(yaw), 0.05]
                orn = pb.getQuaternionFromEuler([0, 0, yaw + 0.4 * k])
                pb.resetBasePositionAndOrientation(sim.robot, pose, orn, physicsClientId=sim.client)
                ranges.append(sim.lidar.ranges())
            casts[threads] = np.array(ranges)
    assert np.isfinite(casts[0]).sum() > 100  # the beams do hit BARN's cylinders
    assert np.array_equal(casts[0], casts[1])
    assert np.array_equal(casts[0], casts[2])


def test_a_pool_worker_casts_on_one_thread(restore_threads):
    set_ray_threads(0)
    one_core_per_worker()
    assert ray_threads() == 1


@pytest.mark.parametrize("bad", [-1, 1.5, "1"])
def test_a_bad_thread_count_is_refused(bad, restore_threads):
    with pytest.raises(ConfigError, match="ray threads"):
        set_ray_threads(bad)
