"""What an episode needs of a simulator backend, and the choice between them
(docs/design/backends.md).

An episode reads a backend through :class:`SimBackend`: the scan (the noise layer's ranges and
the true ones), the ground-truth pose and velocity, a contact test, the estimate, and one
control step under a commanded twist. Two backends give it:

``pybullet``
    :class:`~d3dwa_bullet.sim.simulator.Simulator`, the default and the reference: Bullet's
    contacts and friction over 24 sub-steps a period, ``rayTestBatch`` for the lidar;
``kinematic``
    :class:`~d3dwa_bullet.sim.kinematic.KinematicSimulator`: Kachaka's wheel kinematics, a 2D ray
    cast and a footprint contact test on the world's boxes and cylinders.

Both put the same noise layer (:class:`~d3dwa_bullet.sim.noise.NoiseModel`) between the
physics and the robot, at the same points of the step: latency before the rate limits
(:func:`limit_command`), slip on the wheels, range noise and dropout on the true ranges, the
odometry, gyro and pose fixes fused by :func:`fuse_period`. The kinematic backend may answer a
question only where the agreement study (docs/pilots/kinematic-agreement/) reads it equivalent.

This module imports neither PyBullet nor numba: a command checks ``--backend`` before either.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol, Self

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import RobotLimits, SimParams
from d3dwa_bullet.sim.lidar_params import LidarParams
from d3dwa_bullet.timing import perf
from d3dwa_bullet.world.model import Box, Cylinder, World

if TYPE_CHECKING:  # annotations only: importing either backend loads its engine
    from d3dwa_bullet.sim.estimator import PoseEstimator
    from d3dwa_bullet.sim.noise import NoiseModel
    from d3dwa_bullet.sim.odometry import WheelOdometry
    from d3dwa_bullet.sim.scan import LaserScan
    from d3dwa_bullet.timing import StageClock

BACKENDS = ("pybullet", "kinematic")
"""``--backend`` names; the first is the default and the reference."""
DEFAULT_BACKEND = BACKENDS[0]
_HOMES = {
    "pybullet": ("d3dwa_bullet.sim.simulator", "Simulator"),
    "kinematic": ("d3dwa_bullet.sim.kinematic", "KinematicSimulator"),
}


class SimBackend(Protocol):
    """One Kachaka in one world, as an episode drives it."""

    clock: StageClock
    step_count: int

    @property
    def time(self) -> float:
        """Simulated time since reset, s."""
        ...

    def true_pose(self) -> tuple[float, float, float]:
        """Ground-truth base_link pose (x, y, yaw), m and rad."""
        ...

    def true_velocity(self) -> tuple[float, float]:
        """Ground-truth body-frame (v, w), m/s and rad/s."""
        ...

    def sense(self) -> tuple[LaserScan, np.ndarray]:
        """The scan the robot sees (noise applied) and the true ranges, (beams,) m."""
        ...

    def in_contact(self) -> bool:
        """True if the robot touches an obstacle."""
        ...

    def estimate(self) -> tuple[tuple[float, float, float], tuple[float, float]]:
        """The pose and velocity the robot believes (ground truth without noise)."""
        ...

    def step(self, v: float, w: float) -> tuple[float, float]:
        """One control period under the commanded (v, w); returns the command applied."""
        ...

    def odometry_pose(self) -> tuple[float, float, float]:
        """Raw wheel-odometry pose with noise on, else ground truth."""
        ...

    def close(self) -> None: ...


def check_backend(name: str, gui: bool = False) -> str:
    """name if it is a backend, else ConfigError naming it; ``--gui`` only with PyBullet."""
    if name not in BACKENDS:
        raise ConfigError(f"--backend {name!r}: not one of {', '.join(BACKENDS)}")
    if gui and name != DEFAULT_BACKEND:
        raise ConfigError(f"--gui draws PyBullet's world; --backend {name} has none to draw")
    return name


def check_backend_worlds(name: str, worlds: Sequence[World]) -> None:
    """ConfigError naming the first world and obstacle the backend cannot simulate: the
    kinematic backend casts and touches boxes and cylinders only."""
    if name == DEFAULT_BACKEND:
        return
    for world in worlds:
        for i, ob in enumerate(world.obstacles):
            if not isinstance(ob, Box | Cylinder):
                raise ConfigError(
                    f"world {world.name!r}: obstacle {i} is a {type(ob).__name__}; --backend {name} "
                    "casts boxes and cylinders only (use --backend pybullet)"
                )


def make_simulator(
    name: str,
    world: World,
    sim: SimParams = SimParams(),
    limits: RobotLimits = RobotLimits(),
    lidar: LidarParams = LidarParams(),
    noise: NoiseModel | None = None,
    gui: bool = False,
) -> SimBackend:
    """The named backend's simulator of world (its engine imported only now)."""
    check_backend(name, gui)
    module, cls = _HOMES[name]
    factory = getattr(importlib.import_module(module), cls)
    if gui:
        return factory(world, sim=sim, limits=limits, lidar=lidar, noise=noise, gui=True)  # type: ignore[no-any-return]
    return factory(world, sim=sim, limits=limits, lidar=lidar, noise=noise)  # type: ignore[no-any-return]


def limit_command(
    limits: RobotLimits, dt: float, last: tuple[float, float], v: float, w: float
) -> tuple[float, float]:
    """(v, w) clipped to the velocity limits, then to what the accelerations allow in dt s from
    the last command sent: m/s, rad/s. Reverse to -v_max is allowed (the recovery backs up)."""
    v0, w0 = last
    v = min(max(v, -limits.v_max), limits.v_max)
    w = min(max(w, -limits.w_max), limits.w_max)
    v = min(max(v, v0 - limits.a_max * dt), v0 + limits.a_max * dt)
    w = min(max(w, w0 - limits.alpha_max * dt), w0 + limits.alpha_max * dt)
    return v, w


def fuse_period(
    estimator: PoseEstimator, noise: NoiseModel, t: float, dt: float,
    odom_twist: tuple[float, float], w_true: float, true_pose: tuple[float, float, float],
) -> None:  # fmt: skip
    """Fuse the readings of the period of dt s ending at t: odometry (v, w), the true mean yaw
    rate w_true (rad/s) through the gyro model, predict to t, then any pose fix of true_pose."""
    estimator.update_odometry(*odom_twist)
    estimator.update_gyro(noise.gyro(w_true, dt))
    estimator.predict(t)
    fix = noise.pose_fix(t, true_pose)
    if fix is not None:
        estimator.update_pose_fix(*fix)


class BackendBase:
    """What both backends do alike above their physics: the clock, the noisy scan over the true
    ranges, the estimate, the command's limits and the fusion of a period's readings. A backend
    gives ``true_ranges``, ``true_pose``, ``true_velocity``, ``in_contact``, ``step`` and
    ``close``, and the attributes below."""

    clock: StageClock
    step_count: int
    sim: SimParams
    limits: RobotLimits
    noise: NoiseModel
    noisy: bool
    estimator: PoseEstimator
    odometry: WheelOdometry
    command: tuple[float, float]
    lidar: Any
    """The lidar: ``params`` (:class:`LidarParams`) and ``scan(ranges, stamp_ns)``."""

    @property
    def time(self) -> float:
        """Simulated time since reset, s."""
        return self.step_count * self.sim.control_period

    def true_ranges(self) -> np.ndarray:
        """The lidar's true ranges at the present pose: (beams,) float64, m, +inf: no return."""
        raise NotImplementedError

    def true_pose(self) -> tuple[float, float, float]:
        """Ground-truth base_link pose (x, y, yaw), m and rad."""
        raise NotImplementedError

    def true_velocity(self) -> tuple[float, float]:
        """Ground-truth body-frame (v, w): m/s, rad/s."""
        raise NotImplementedError

    def close(self) -> None:
        """Release what the backend holds."""

    def estimate(self) -> tuple[tuple[float, float, float], tuple[float, float]]:
        """The pose and velocity the robot believes: EKF with noise on, ground truth without."""
        if not self.noisy:
            return self.true_pose(), self.true_velocity()
        est = self.estimator
        return tuple(float(v) for v in est.pose), tuple(float(v) for v in est.velocity)  # type: ignore[return-value]

    def sense(self) -> tuple[LaserScan, np.ndarray]:
        """The scan the robot sees (noise applied) and the true ranges, (beams,) m."""
        clock, t = self.clock, perf()
        true = self.true_ranges()
        prm = self.lidar.params
        t = clock.charge("lidar", t)
        seen = self.noise.corrupt_ranges(true, prm.range_min, prm.range_max) if self.noisy else true
        t = clock.charge("noise", t)
        scan = self.lidar.scan(seen, int(round(self.time * 1e9)))
        clock.charge("lidar", t)
        return scan, true

    def limit_command(self, v: float, w: float) -> tuple[float, float]:
        """(v, w) clipped to the velocity limits and to what the accelerations allow this period
        (:func:`limit_command`)."""
        return limit_command(self.limits, self.sim.control_period, self.command, v, w)

    def _take_command(self, v: float, w: float) -> np.ndarray:
        """Start a period under command (v, w): the noise layer's latency, then the limits (the
        result kept as ``self.command``); returns the wheels' slip ratios this period, (2,)."""
        cmd = self.noise.delay((v, w)) if self.noisy else (v, w)
        self.command = self.limit_command(*cmd)
        return self.noise.wheel_slip_ratio() if self.noisy else np.zeros(2)

    def _fuse(self, t: float, odom_twist: tuple[float, float], w_true: float) -> None:
        """Fuse the readings of the period ending at t (s): odometry (v, w) and the true mean
        yaw rate w_true (rad/s) through the gyro model, then predict to t, then any pose fix."""
        fuse_period(
            self.estimator, self.noise, t, self.sim.control_period, odom_twist, w_true,
            self.true_pose(),
        )  # fmt: skip

    def odometry_pose(self) -> tuple[float, float, float]:
        """Raw wheel-odometry pose (noise on), else ground truth."""
        return tuple(self.odometry.pose) if self.noisy else self.true_pose()  # type: ignore[return-value]

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
