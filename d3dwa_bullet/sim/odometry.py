"""Wheel odometry: encoder wheel speeds -> (x, y, yaw, v, w) with the robot's believed geometry.

The robot believes its wheels have radius ``wheel_radius * scale_left/right`` and its track is
``track * track_scale``, where the scales are this episode's systematic calibration errors
(``1 + N(0, std)``, see :class:`~d3dwa_bullet.sim.noise_config.OdometryConfig`). The pose is
integrated exactly along the constant-(v, w) arc of each update
(:func:`~d3dwa_bullet.geometry.arc_step`), then a random walk is added to it.
"""

from __future__ import annotations

import math

import numpy as np

from d3dwa_bullet.errors import ConfigError, EstimatorError
from d3dwa_bullet.geometry import arc_step, wrap_angle_modular
from d3dwa_bullet.robot import TRACK, WHEEL_RADIUS
from d3dwa_bullet.sim.noise_config import OdometryConfig

#: Sampled geometry scales are clipped here so a wild std can never flip or zero a wheel.
SCALE_CLIP = (0.5, 1.5)
#: Exact odometry (the default).
NO_ERRORS = OdometryConfig()


class WheelOdometry:
    """Dead reckoning from the two drive wheels' encoder speeds.

    wheel_radius, track: the *true* geometry, m (default Kachaka's, :mod:`d3dwa_bullet.robot`).
    config: systematic errors and random walk (default: none, exact odometry).
    rng: the odometry stream (``NoiseModel.odometry_rng``); required when config is on.
    """

    def __init__(
        self,
        wheel_radius: float = WHEEL_RADIUS,
        track: float = TRACK,
        config: OdometryConfig = NO_ERRORS,
        rng: np.random.Generator | None = None,
    ):
        for name, value in (("wheel_radius", wheel_radius), ("track", track)):
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"WheelOdometry.{name} must be a positive number, got {value!r}")
        if config.enabled and rng is None:
            raise ConfigError("WheelOdometry: an rng is required when the odometry errors are on")
        self.config = config
        self.rng = rng
        scales = np.ones(3)
        if config.enabled:
            assert rng is not None
            std = np.array(
                [config.radius_error_std, config.radius_error_std, config.track_error_std]
            )
            scales = np.clip(1.0 + std * rng.normal(0.0, 1.0, size=3), *SCALE_CLIP)
        self.radius_left = wheel_radius * float(scales[0])
        """Believed left wheel radius, m."""
        self.radius_right = wheel_radius * float(scales[1])
        """Believed right wheel radius, m."""
        self.track = track * float(scales[2])
        """Believed track (wheel separation), m."""
        self.reset()

    def reset(self, pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Restart integration at pose (x, y, yaw), m/rad. Keeps the sampled geometry errors."""
        self.x, self.y, self.yaw = (float(p) for p in pose)
        self.v = 0.0
        self.w = 0.0

    @property
    def pose(self) -> tuple[float, float, float]:
        """Integrated (x, y, yaw), m/rad, odometry frame; yaw in [-pi, pi)."""
        return self.x, self.y, self.yaw

    def update(
        self, omega_left: float, omega_right: float, dt: float
    ) -> tuple[float, float, float, float, float]:
        """Integrate encoder speeds (rad/s) over dt (s). Returns (x, y, yaw, v, w).

        v (m/s) and w (rad/s) are the encoder-derived body velocities (no random walk on them).
        """
        for name, value in (("omega_left", omega_left), ("omega_right", omega_right), ("dt", dt)):
            if not math.isfinite(value):
                raise EstimatorError(f"WheelOdometry.update: {name} = {value!r} is not finite")
        if dt < 0:
            raise EstimatorError(f"WheelOdometry.update: dt = {dt!r} is negative")
        v_left = omega_left * self.radius_left
        v_right = omega_right * self.radius_right
        self.v = 0.5 * (v_left + v_right)
        self.w = (v_right - v_left) / self.track
        x, y, yaw = arc_step(self.x, self.y, self.yaw, self.v, self.w, dt)
        cfg = self.config
        if cfg.enabled:
            assert self.rng is not None
            e = self.rng.normal(0.0, 1.0, size=3) * math.sqrt(dt)
            x += cfg.walk_std * float(e[0])
            y += cfg.walk_std * float(e[1])
            yaw += cfg.yaw_walk_std * float(e[2])
        self.x, self.y, self.yaw = x, y, wrap_angle_modular(yaw)
        return self.x, self.y, self.yaw, self.v, self.w
