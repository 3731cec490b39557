"""The simulated 2D lidar: ``rayTestBatch`` from the lidar link over its field of view."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from .errors import ConfigError
from .scan import LaserScan, Pose2D


@dataclass(frozen=True)
class LidarParams:
    """Kachaka's 2D lidar as mounted in base_link (SPEC section 3)."""

    fov: float = math.radians(240.0)
    """Field of view, rad, centred forward."""
    increment: float = math.radians(0.5)
    """Beam spacing, rad."""
    range_min: float = 0.05
    """Closest usable return, m."""
    range_max: float = 10.0
    """Farthest return, m; beyond it a beam reads +inf (REP-117 "no return")."""
    mount_x: float = 0.156
    mount_y: float = 0.0
    mount_z: float = 0.105
    """Lidar origin in base_link, m."""

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


class Lidar:
    """Casts the beams of one robot in one PyBullet client."""

    def __init__(self, client: int, robot: int, params: LidarParams = LidarParams()):
        self.client, self.robot, self.params = client, robot, params
        a = params.angles()
        self._dirs = np.column_stack((np.cos(a), np.sin(a)))  # lidar frame, unit

    def ranges(self, pose: tuple[float, float, float], base_z: float) -> np.ndarray:
        """True ranges from base_link pose (x, y, yaw) and its height: (beams,) float64, m.

        A beam with no hit within range_max reads +inf; hits on the robot itself are ignored.
        """
        prm = self.params
        x, y, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        ox = x + c * prm.mount_x - s * prm.mount_y
        oy = y + s * prm.mount_x + c * prm.mount_y
        oz = base_z + prm.mount_z
        dx = c * self._dirs[:, 0] - s * self._dirs[:, 1]
        dy = s * self._dirs[:, 0] + c * self._dirs[:, 1]
        n = len(dx)
        start = np.column_stack((np.full(n, ox), np.full(n, oy), np.full(n, oz)))
        end = start + prm.range_max * np.column_stack((dx, dy, np.zeros(n)))
        hits = p.rayTestBatch(start.tolist(), end.tolist(), physicsClientId=self.client)
        uid = np.fromiter((h[0] for h in hits), dtype=np.int64, count=n)
        frac = np.fromiter((h[2] for h in hits), dtype=np.float64, count=n)
        out = frac * prm.range_max
        out[(uid < 0) | (uid == self.robot)] = np.inf
        return out

    def scan(self, ranges: np.ndarray, stamp_ns: int) -> LaserScan:
        """Wrap ranges into a LaserScan record, every float rounded to float32 as
        sensor_msgs/LaserScan stores it: a recorded bag then replays bit for bit."""
        prm = self.params
        f32 = np.float32
        return LaserScan(
            float(f32(prm.angle_min)), float(f32(prm.increment)),
            np.asarray(ranges, dtype=f32).astype(np.float64),
            float(f32(prm.range_min)), float(f32(prm.range_max)), stamp_ns,
        )  # fmt: skip
