"""A synthetic Kachaka bag without a simulator: driving straight down a walled corridor.

For tests, demos and checking a replay set-up end to end. The scans are computed in closed
form (walls at y = +-half_width, an end wall at x = end_x), optionally with Gaussian range
noise and REP-117 dropouts drawn from one seeded generator.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from d3dwa_bullet.sim.scan import LaserScan
from transfer.bag_writer import LIDAR_MOUNT_XYZ, BagRecorder, Storage, quantize_scan
from transfer.topics import TopicMap

#: Dropout kind -> the value a driver writes for it.
DROPOUT_VALUES = {"nan": np.nan, "pos_inf": np.inf, "neg_inf": -np.inf, "zero": 0.0}


@dataclass(frozen=True)
class Corridor:
    """Geometry, lidar and motion of the synthetic run. SI units, odometry frame."""

    half_width: float = 1.0
    end_x: float = 6.0
    speed: float = 0.2
    beams: int = 241
    fov: float = float(np.deg2rad(240.0))
    range_min: float = 0.05
    range_max: float = 10.0


def corridor_scan(x: float, corridor: Corridor, stamp_ns: int = 0) -> LaserScan:
    """Noise-free scan with the robot at (x, 0, yaw 0); walls beyond range_max read +inf."""
    c = corridor
    inc = c.fov / (c.beams - 1)
    a = -0.5 * c.fov + inc * np.arange(c.beams)
    lx = x + LIDAR_MOUNT_XYZ[0]
    s, co = np.sin(a), np.cos(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        side = np.where(s != 0, c.half_width / np.abs(s), np.inf)
        end = np.where(co > 0, (c.end_x - lx) / co, np.inf)
    r = np.minimum(side, end)
    r[r > c.range_max] = np.inf
    return LaserScan(-0.5 * c.fov, inc, r, c.range_min, c.range_max, stamp_ns=stamp_ns)


def write_corridor_bag(
    path: str | Path,
    *,
    n_scans: int = 20,
    start_ns: int = 1_000_000_000,
    period_ns: int = 100_000_000,
    corridor: Corridor = Corridor(),
    goal: tuple[float, float] | None = (5.0, 0.0),
    noise_std: float = 0.0,
    dropout: dict[str, float] | None = None,
    seed: int = 0,
    storage: Storage = "sqlite3",
    topics: TopicMap | None = None,
    params: tuple[float, float, float, float, float] | None = (1.0, 2.0, 1.0, 4.0, 30.0),
    overwrite: bool = False,
) -> list[tuple[int, LaserScan, np.ndarray]]:
    """Write the run; returns (t_ns, recorded scan (float32-exact), odometry pose (3,)) per step.

    dropout: kind ('nan', 'pos_inf', 'neg_inf', 'zero') -> per-beam probability.
    """
    rng = np.random.default_rng(seed)
    steps = []
    with BagRecorder(path, storage=storage, topics=topics, goal=goal, overwrite=overwrite) as rec:
        for k in range(n_scans):
            t = start_ns + k * period_ns
            x = corridor.speed * k * period_ns / 1e9
            scan = corridor_scan(x, corridor, stamp_ns=t)
            r = scan.ranges.copy()
            if noise_std > 0:
                r = r + rng.normal(0.0, noise_std, r.size)
            for kind, p in (dropout or {}).items():
                r[rng.random(r.size) < p] = DROPOUT_VALUES[kind]
            scan = quantize_scan(
                LaserScan(
                    scan.angle_min, scan.angle_increment, r, scan.range_min, scan.range_max, t
                )
            )
            pose = np.array([x, 0.0, 0.0])
            twist = (corridor.speed, 0.0)
            rec.write_step(t, scan, pose, twist, pose, twist, 0.0, twist, params)
            steps.append((t, scan, pose))
    return steps
