"""The simulation layer: the PyBullet shell and the robot's sensing and estimation.

Modules: ``simulator`` (``Simulator``: a driven Kachaka in a static world), ``lidar`` (the
2D lidar's rays), ``bullet`` (the one PyBullet import, without its start-up banner),
``scan`` (the ``LaserScan`` record and ``Pose2D``), ``odometry`` (wheel odometry),
``estimator`` (the EKF), ``noise_config`` (what each noise model does) and ``noise``
(``NoiseModel``: one episode's seeded noise).

The names below are re-exported lazily: each is imported on first access, so importing a
pure module such as ``d3dwa_bullet.sim.scan`` (which runs this file first) pulls in no
pybullet. Modules inside the package import each other directly, never through here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from d3dwa_bullet.lazy import lazy_exports

if TYPE_CHECKING:
    from d3dwa_bullet.sim.estimator import EstimatorConfig, PoseEstimator
    from d3dwa_bullet.sim.lidar import Lidar, LidarParams
    from d3dwa_bullet.sim.noise import (
        NoiseModel,
        PhysicsScales,
        encoder_wheel_speed,
        ground_wheel_speed,
    )
    from d3dwa_bullet.sim.noise_config import (
        ImuConfig,
        LatencyConfig,
        LidarNoiseConfig,
        NoiseConfig,
        OdometryConfig,
        PhysicsConfig,
        PoseFixConfig,
        SlipConfig,
    )
    from d3dwa_bullet.sim.odometry import WheelOdometry
    from d3dwa_bullet.sim.scan import LaserScan, Pose2D
    from d3dwa_bullet.sim.simulator import DriveParams, Simulator

_HOMES = {
    "EstimatorConfig": "d3dwa_bullet.sim.estimator",
    "PoseEstimator": "d3dwa_bullet.sim.estimator",
    "Lidar": "d3dwa_bullet.sim.lidar",
    "LidarParams": "d3dwa_bullet.sim.lidar",
    "NoiseModel": "d3dwa_bullet.sim.noise",
    "PhysicsScales": "d3dwa_bullet.sim.noise",
    "encoder_wheel_speed": "d3dwa_bullet.sim.noise",
    "ground_wheel_speed": "d3dwa_bullet.sim.noise",
    "ImuConfig": "d3dwa_bullet.sim.noise_config",
    "LatencyConfig": "d3dwa_bullet.sim.noise_config",
    "LidarNoiseConfig": "d3dwa_bullet.sim.noise_config",
    "NoiseConfig": "d3dwa_bullet.sim.noise_config",
    "OdometryConfig": "d3dwa_bullet.sim.noise_config",
    "PhysicsConfig": "d3dwa_bullet.sim.noise_config",
    "PoseFixConfig": "d3dwa_bullet.sim.noise_config",
    "SlipConfig": "d3dwa_bullet.sim.noise_config",
    "WheelOdometry": "d3dwa_bullet.sim.odometry",
    "LaserScan": "d3dwa_bullet.sim.scan",
    "Pose2D": "d3dwa_bullet.sim.scan",
    "DriveParams": "d3dwa_bullet.sim.simulator",
    "Simulator": "d3dwa_bullet.sim.simulator",
}
"""Re-exported name -> the module that defines it."""

__all__ = [
    "DriveParams",
    "EstimatorConfig",
    "ImuConfig",
    "LaserScan",
    "LatencyConfig",
    "Lidar",
    "LidarNoiseConfig",
    "LidarParams",
    "NoiseConfig",
    "NoiseModel",
    "OdometryConfig",
    "PhysicsConfig",
    "PhysicsScales",
    "Pose2D",
    "PoseEstimator",
    "PoseFixConfig",
    "Simulator",
    "SlipConfig",
    "WheelOdometry",
    "encoder_wheel_speed",
    "ground_wheel_speed",
]


# Imported on first access: the simulator, lidar and estimator need pybullet or filterpy.
__getattr__, __dir__ = lazy_exports(globals(), _HOMES)
