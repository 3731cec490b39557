"""The noise axes of the sweep: one noise source each, swept from 0 to a harsh level.

A level L of an axis is an explicit :class:`NoiseConfig` with every other model off (the
table in :mod:`d3dwa_bullet.evaluation.sweep` lists what each axis sets).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from d3dwa_bullet.sim.noise_config import LidarNoiseConfig, NoiseConfig, OdometryConfig, SlipConfig

DROPOUT_KINDS = (0.1, 0.7, 0.2)
"""(NaN, +inf, 0.0) proportions of dropped beams, as in the ``real`` profile."""


@dataclass(frozen=True)
class NoiseAxis:
    """One noise source swept from 0 to ``harsh``."""

    name: str
    label: str
    """Axis label for plots, with unit."""
    sets: str
    """What a level L sets (for reports)."""
    harsh: float
    """The top of the axis (several times the ``harsh`` profile)."""
    build: Callable[[float], NoiseConfig] = field(repr=False, compare=False)
    """Level -> the episode's NoiseConfig (every other model off)."""

    def levels(self, n: int) -> list[float]:
        """The n non-zero levels, equally spaced up to harsh."""
        return [round(self.harsh * i / n, 6) for i in range(1, n + 1)]


AXES: dict[str, NoiseAxis] = {
    a.name: a
    for a in (
        NoiseAxis(
            "lidar_dropout",
            "lidar beam dropout probability",
            "lidar.dropout_prob = L; dropped beams read NaN / +inf / 0 in proportions 1:7:2",
            0.5,
            lambda v: NoiseConfig(
                lidar=LidarNoiseConfig(dropout_prob=v, dropout_kinds=DROPOUT_KINDS)
            ),
        ),
        NoiseAxis(
            "lidar_range",
            "lidar range noise std [m]",
            "lidar.range_std = L m (Gaussian, on valid returns)",
            0.10,
            lambda v: NoiseConfig(lidar=LidarNoiseConfig(range_std=v)),
        ),
        NoiseAxis(
            "slip",
            "wheel slip ratio (per-episode mean)",
            "slip.level_mean = L, level_std = L/4 (wheels differ), step_std = L/10",
            0.4,
            lambda v: NoiseConfig(slip=SlipConfig(level_mean=v, level_std=v / 4, step_std=v / 10)),
        ),
        NoiseAxis(
            "odometry",
            "odometry drift level L",
            "odometry.walk_std = L m/√s, yaw_walk_std = L rad/√s, "
            "radius_error_std = track_error_std = L",
            0.04,
            lambda v: NoiseConfig(
                odometry=OdometryConfig(
                    radius_error_std=v, track_error_std=v, walk_std=v, yaw_walk_std=v
                )
            ),
        ),
    )
}
