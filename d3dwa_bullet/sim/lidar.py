"""The simulated 2D lidar: ``rayTestBatch`` from the lidar link over its field of view."""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import itemgetter

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.robot import LIDAR_MOUNT
from d3dwa_bullet.sim.bullet import p
from d3dwa_bullet.sim.scan import LaserScan, Pose2D


@dataclass(frozen=True)
class LidarParams:
    """Kachaka's 2D lidar as mounted in base_link (docs/design.md#lidar)."""

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


class Lidar:
    """Casts the beams of one robot in one PyBullet client.

    Rays are given in the lidar link's own frame (``parentObjectUniqueId`` /
    ``parentLinkIndex``), so Bullet places them from the link's current pose and the ray
    lists are built once. The lidar sits above the body, so no beam can hit the robot.
    ``numThreads=0`` lets Bullet spread the beams over the cores; each beam's result does not
    depend on the threading.
    """

    def __init__(self, client: int, robot: int, link: int, params: LidarParams = LidarParams()):
        self.client, self.robot, self.link, self.params = client, robot, link, params
        a = params.angles()
        self._from = [[0.0, 0.0, 0.0]] * len(a)
        self._to = (
            params.range_max * np.column_stack((np.cos(a), np.sin(a), np.zeros(len(a))))
        ).tolist()

    def ranges(self) -> np.ndarray:
        """True ranges at the link's current pose: (beams,) float64, m; +inf where no hit."""
        hits = p.rayTestBatch(
            self._from, self._to, parentObjectUniqueId=self.robot, parentLinkIndex=self.link,
            numThreads=0, physicsClientId=self.client,
        )  # fmt: skip
        frac = np.fromiter(map(itemgetter(2), hits), dtype=np.float64, count=len(self._to))
        out = frac * self.params.range_max
        out[frac >= 1.0] = np.inf
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
