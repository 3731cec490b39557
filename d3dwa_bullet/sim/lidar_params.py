"""The lidar's parameters (field of view, beams, range, mount): pure, so a command can check
them, and an episode's configuration can hold them, without importing PyBullet."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.robot import LIDAR_MOUNT
from d3dwa_bullet.sim.scan import Pose2D


@dataclass(frozen=True)
class LidarParams:
    """Kachaka's 2D lidar as mounted in base_link (docs/design/robot.md#lidar)."""

    fov: float = math.radians(240.0)
    """Field of view, rad, centred forward."""
    increment: float = math.radians(0.5)
    """Beam spacing, rad."""
    range_min: float = 0.05
    """Closest usable return, m."""
    range_max: float = 10.0
    """Farthest return, m; beyond it a beam reads +inf (REP-117 "no return")."""
    mount_x: float = LIDAR_MOUNT[0]
    mount_y: float = LIDAR_MOUNT[1]
    mount_z: float = LIDAR_MOUNT[2]
    """Lidar origin in base_link, m (default Kachaka's, :mod:`d3dwa_bullet.robot`)."""

    def __post_init__(self) -> None:
        if not (0 < self.fov <= 2 * math.pi) or self.increment <= 0:
            raise ConfigError(f"LidarParams: need 0 < fov <= 2 pi and increment > 0, got {self!r}")
        if not 0 <= self.range_min < self.range_max:
            raise ConfigError(f"LidarParams: need 0 <= range_min < range_max, got {self!r}")

    @property
    def beams(self) -> int:
        """Beam count: both ends of the field of view included (481 by default)."""
        return int(round(self.fov / self.increment)) + 1

    @property
    def angle_min(self) -> float:
        return -0.5 * self.fov

    @property
    def mount(self) -> Pose2D:
        return Pose2D(self.mount_x, self.mount_y, 0.0)

    def angles(self) -> np.ndarray:
        """(beams,) beam angles in the lidar frame, rad."""
        return self.angle_min + self.increment * np.arange(self.beams)


_ray_threads = [0]  # the process's setting, read by every Lidar at each cast


def set_ray_threads(threads: int) -> None:
    """Threads of ``rayTestBatch`` for every lidar in this process: 0 lets Bullet use every core
    (one simulator alone on the machine), 1 keeps the beams on the caller's thread (a pool worker
    beside others: ``backends.one_core_per_worker``). Each beam's range is the same either way."""
    if not (isinstance(threads, int) and threads >= 0):
        raise ConfigError(f"ray threads must be an integer >= 0, got {threads!r}")
    _ray_threads[0] = threads


def ray_threads() -> int:
    """The process's ``rayTestBatch`` thread count (``set_ray_threads``; 0 = every core)."""
    return _ray_threads[0]
