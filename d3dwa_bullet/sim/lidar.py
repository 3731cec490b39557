"""The simulated 2D lidar: ``rayTestBatch`` from the lidar link over its field of view.

``LidarParams`` lives in :mod:`d3dwa_bullet.sim.lidar_params` (pure) and is re-exported here."""

from __future__ import annotations

from operator import itemgetter

import numpy as np

from d3dwa_bullet.sim.bullet import p
from d3dwa_bullet.sim.lidar_params import LidarParams, ray_threads  # LidarParams: its old home
from d3dwa_bullet.sim.scan import LaserScan


class Lidar:
    """Casts the beams of one robot in one PyBullet client.

    Rays are given in the lidar link's own frame (``parentObjectUniqueId`` /
    ``parentLinkIndex``), so Bullet places them from the link's current pose and the ray
    lists are built once. The lidar sits above the body, so no beam can hit the robot.
    The batch runs on ``lidar_params.ray_threads()`` threads: 0 (the default) lets Bullet spread
    the beams over the cores, which one simulator alone on an idle machine gains from (one thread
    measured 21 % slower there); a pool worker sets 1 (``backends.one_core_per_worker``), since
    ``--workers N`` on N cores oversubscribed them otherwise (docs/design/episode-cost.md). Each
    beam's result does not depend on the threading.
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
            numThreads=ray_threads(), physicsClientId=self.client,
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
