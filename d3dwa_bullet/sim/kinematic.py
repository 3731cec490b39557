"""The kinematic backend: Kachaka driven as a unicycle in a plane of boxes and circles
(docs/design/backends.md).

The same control step as :class:`~d3dwa_bullet.sim.simulator.Simulator`, in the same order and
with the same noise: the command enters the latency FIFO, is clipped and rate-limited by
:func:`~d3dwa_bullet.sim.backend.limit_command`, turns into wheel speeds, slip takes ``s`` of
each wheel's ground speed (the encoders count all of it), then the robot moves for one control
period, then odometry, gyro and EKF as there. Motion replaces Bullet's 24 contact sub-steps:

- each wheel's speed follows its target at the acceleration its motor's torque limit gives the
  robot's mass (``TORQUE_ACCEL``: 9.4 m/s^2 at nominal torque and mass), so the episode's
  sampled torque and mass scales act as they do in Bullet; friction's scale does not act (the
  wheels never skid at the planner's 2 m/s^2 on a friction of 1);
- the ground moves at ``ROLLING_RADIUS`` per wheel radian over an effective track
  ``EFFECTIVE_TRACK``: PyBullet loads the URDF's wheel cylinders as convex hulls with a 1 mm
  collision margin, so the robot rolls on a radius of 46 mm where the encoders and odometry
  assume 45 mm (2.2 % faster than commanded), and turns as on a 5 % wider track;
- the pose integrates the sub-steps at 240 Hz as Bullet does (exact arcs).

Contact is the body box (:mod:`d3dwa_bullet.robot`) within ``CONTACT_MARGIN`` of an obstacle.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from d3dwa_bullet.geometry import wrap_angle_modular
from d3dwa_bullet.params import RobotLimits, SimParams
from d3dwa_bullet.robot import (
    AXLE_HEIGHT,
    BODY_CENTER_X,
    BODY_HALF_LENGTH,
    BODY_HALF_WIDTH,
    TRACK,
    WHEEL_RADIUS,
)
from d3dwa_bullet.sim.backend import BackendBase
from d3dwa_bullet.sim.estimator import PoseEstimator
from d3dwa_bullet.sim.lidar_params import LidarParams
from d3dwa_bullet.sim.noise import NoiseModel, encoder_wheel_speed, ground_wheel_speed
from d3dwa_bullet.sim.odometry import WheelOdometry
from d3dwa_bullet.sim.planar import body_touches, cast_rays, pack_obstacles
from d3dwa_bullet.sim.scan import LaserScan
from d3dwa_bullet.timing import StageClock, perf
from d3dwa_bullet.world.model import World

HULL_MARGIN = 0.001
"""Bullet's collision margin around the convex hull of a URDF cylinder, m (``getDynamicsInfo``)."""
ROLLING_RADIUS = WHEEL_RADIUS + HULL_MARGIN
"""Radius the simulated wheels roll on, m (the hull's margin adds to the URDF's radius)."""
EFFECTIVE_TRACK = 0.21
"""Track that maps wheel speeds to Bullet's yaw rate, m: the best of a grid fitted to PyBullet's
paths under random commands (``python -m tools.bench.kinematic_calibration``), 5 % over
``TRACK``: the 25 mm wide hulls touch the floor off their mid-planes."""
BASE_MASS = 6.4
"""Mass of base_link in the URDF, kg (the part the physics randomisation's mass scale acts on)."""
OTHER_MASS = 0.71
"""The URDF's wheels, casters, lidar and IMU together, kg."""
WHEEL_TORQUE = 1.5
"""Torque limit per wheel motor, N m (``DriveParams.wheel_torque``)."""
CONTACT_MARGIN = 0.0
"""Distance within which the body box touches an obstacle, m."""


def torque_accel(torque_scale: float = 1.0, mass_scale: float = 1.0) -> float:
    """Largest forward acceleration both wheels' motors give the robot, m/s^2."""
    mass = BASE_MASS * mass_scale + OTHER_MASS
    return 2.0 * WHEEL_TORQUE * torque_scale / (WHEEL_RADIUS * mass)


@numba.njit(cache=True, nogil=True)
def drive_period(
    x: float, y: float, yaw: float, wheels: np.ndarray, target: np.ndarray, max_step: float,
    substeps: int, dt: float, radius: float, track: float,
) -> tuple[float, float, float, float, float]:  # fmt: skip
    """Move the robot one control period: each of ``substeps`` steps of ``dt`` s, the (2,) joint
    speeds ``wheels`` (rad/s, updated in place) step towards ``target`` by at most ``max_step``,
    then the pose (m, rad) follows the exact arc of the resulting twist. Returns (x, y, yaw, mean
    left joint speed, mean right joint speed) over the period."""
    mean_l = mean_r = 0.0
    for _ in range(substeps):
        for j in range(2):
            d = target[j] - wheels[j]
            wheels[j] += min(max(d, -max_step), max_step)
        mean_l += wheels[0] / substeps
        mean_r += wheels[1] / substeps
        v = 0.5 * radius * (wheels[0] + wheels[1])
        w = radius * (wheels[1] - wheels[0]) / track
        if abs(w) < 1e-9:
            x += v * dt * math.cos(yaw)
            y += v * dt * math.sin(yaw)
        else:
            x += v / w * (math.sin(yaw + w * dt) - math.sin(yaw))
            y -= v / w * (math.cos(yaw + w * dt) - math.cos(yaw))
        yaw += w * dt
    yaw = math.atan2(math.sin(yaw), math.cos(yaw))
    return x, y, yaw, mean_l, mean_r


class LidarModel:
    """The planar lidar's parameters and its scan record (what ``Simulator.lidar`` offers)."""

    def __init__(self, params: LidarParams):
        self.params = params

    def scan(self, ranges: np.ndarray, stamp_ns: int) -> LaserScan:
        """ranges wrapped as a LaserScan, floats rounded to float32 as the PyBullet lidar does."""
        prm, f32 = self.params, np.float32
        return LaserScan(
            float(f32(prm.angle_min)), float(f32(prm.increment)),
            np.asarray(ranges, dtype=f32).astype(np.float64),
            float(f32(prm.range_min)), float(f32(prm.range_max)), stamp_ns,
        )  # fmt: skip


class KinematicSimulator(BackendBase):
    """One Kachaka in one world, without physics: the :class:`~d3dwa_bullet.sim.backend.SimBackend`
    of ``--backend kinematic``. ConfigError for a world with a shape it cannot cast."""

    def __init__(
        self,
        world: World,
        sim: SimParams = SimParams(),
        limits: RobotLimits = RobotLimits(),
        lidar: LidarParams = LidarParams(),
        noise: NoiseModel | None = None,
    ):
        self.world, self.sim, self.limits = world, sim, limits
        self.rows = pack_obstacles(world)
        self.noise = noise if noise is not None else NoiseModel()
        self.noisy = self.noise.config.enabled
        self.clock = StageClock()
        """Seconds per stage of the control steps so far (physics, lidar, noise, estimator)."""
        self.lidar = LidarModel(lidar)
        self._z = AXLE_HEIGHT + lidar.mount_z
        self._max_step = (
            torque_accel(self.noise.torque_scale, self.noise.mass_scale) / WHEEL_RADIUS / sim.physics_hz
        )  # fmt: skip
        self.pose = tuple(float(v) for v in world.start)
        self.wheels = np.zeros(2)  # joint speeds (left, right), rad/s
        self.odometry = WheelOdometry(
            WHEEL_RADIUS, TRACK, self.noise.config.odometry, self.noise.odometry_rng
        )
        self.odometry.reset(world.start)
        self.estimator = PoseEstimator(pose=world.start, t=0.0)
        self.step_count = 0
        self.command = (0.0, 0.0)
        self.velocity_estimate = (0.0, 0.0)
        if self.noisy:
            self._fuse(0.0, (0.0, 0.0), 0.0)

    def true_pose(self) -> tuple[float, float, float]:
        """Ground-truth base_link pose (x, y, yaw), m and rad."""
        return self.pose  # type: ignore[return-value]

    def true_velocity(self) -> tuple[float, float]:
        """Ground-truth body-frame (v, w): m/s, rad/s."""
        left, right = self.wheels
        return (
            float(0.5 * ROLLING_RADIUS * (left + right)),
            float(ROLLING_RADIUS * (right - left) / EFFECTIVE_TRACK),
        )

    def in_contact(self) -> bool:
        """True if the body box touches an obstacle."""
        x, y, yaw = self.pose
        return bool(
            body_touches(self.rows, x, y, yaw, BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH,
                         CONTACT_MARGIN)
        )  # fmt: skip

    def true_ranges(self) -> np.ndarray:
        """The lidar's true ranges at the present pose: (beams,) float64, m, +inf for no return."""
        x, y, yaw = self.pose
        prm = self.lidar.params
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy = x + c * prm.mount_x - s * prm.mount_y, y + s * prm.mount_x + c * prm.mount_y
        return cast_rays(
            self.rows, ox, oy, yaw, self._z, prm.angle_min, prm.increment, prm.beams, prm.range_max
        )

    def step(self, v: float, w: float) -> tuple[float, float]:
        """Run one control period under command (v, w). Returns the command applied."""
        clock, t = self.clock, perf()
        slip = self._take_command(v, w)
        t = clock.charge("noise", t)
        cv, cw = self.command
        omega = np.array(
            [(cv - 0.5 * TRACK * cw) / WHEEL_RADIUS, (cv + 0.5 * TRACK * cw) / WHEEL_RADIUS]
        )
        target = ground_wheel_speed(omega, slip) if self.noisy else omega
        x, y, yaw = self.pose
        dt = self.sim.control_period
        x, y, new_yaw, mean_l, mean_r = drive_period(
            x, y, yaw, self.wheels, target, self._max_step, self.sim.substeps,
            dt / self.sim.substeps, ROLLING_RADIUS, EFFECTIVE_TRACK,
        )  # fmt: skip
        self.pose = (float(x), float(y), float(new_yaw))
        self.step_count += 1
        t = clock.charge("physics", t)
        if self.noisy:
            enc = encoder_wheel_speed(np.array([mean_l, mean_r]), slip)
            w_mean = wrap_angle_modular(new_yaw - yaw) / dt
            _, _, _, ov, ow = self.odometry.update(float(enc[0]), float(enc[1]), dt)
            self._fuse(self.time, (ov, ow), w_mean)
            clock.charge("estimator", t)
        return self.command

    def close(self) -> None:
        """Nothing to release (no physics client)."""
