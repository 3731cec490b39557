"""Bags of a robot with known sensor errors, for checking ``d3dwa calibrate`` (tests, tools).

A differential-drive robot stands still for ``still_s`` seconds, then drives loops of
varying curvature inside a closed rectangular room, so every beam hits a wall. Everything is
closed form and drawn from one seeded generator:

* scans: true ranges to the room's walls, plus Gaussian range noise on valid returns,
  phantom short returns uniform in [spurious_min, spurious_max], and dropout with a
  per-sector probability and a per-sector mix of NaN / +inf / -inf / 0.0 / out of range.
  Sectors are the observation's (``transfer.compare.beam_sectors``, by beam direction), a
  different implementation from the simulator's noise model on purpose;
* reference odometry: the true pose and twist (what a calibration reference should be);
* wheel odometry: believed wheel radii ``r * scale_left/right`` and track ``track * scale``
  applied to the true wheel speeds, integrated along arcs, plus a random walk;
* IMU: the true yaw rate plus a constant bias and white noise.

Roles whose topic is None in ``topics`` are not written (no IMU, no wheel odometry, ...).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from d3dwa_bullet.geometry import arc_step
from d3dwa_bullet.params import ObservationParams
from d3dwa_bullet.robot import TRACK
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from transfer.bag_writer import LIDAR_MOUNT_XYZ, BagRecorder, quantize_scan
from transfer.compare import beam_sectors
from transfer.topics import TopicMap

#: Value a driver writes for each dropout kind, in ``transfer.compare.READING_CLASSES`` order.
KIND_VALUES = (math.nan, math.inf, -math.inf, 0.0, None)  # None: out of range (range_max * 2)


@dataclass(frozen=True)
class SyntheticLidar:
    """Scanner geometry and its known errors."""

    beams: int = 481
    fov_deg: float = 240.0
    """angle_max - angle_min."""
    rate_hz: float = 10.0
    range_min: float = 0.05
    range_max: float = 10.0
    range_std: float = 0.02
    dropout: tuple[float, ...] = (0.10, 0.10, 0.02, 0.02, 0.02, 0.02, 0.05, 0.05)
    """Dropout probability per observation sector (beams outside the sectors: the mean)."""
    kinds: tuple[float, float, float, float, float] = (0.2, 0.4, 0.1, 0.2, 0.1)
    """(NaN, +inf, -inf, 0.0, out of range) mix of dropped beams, every sector."""
    spurious_prob: float = 0.004
    spurious_min: float = 0.2
    spurious_max: float = 0.8


@dataclass(frozen=True)
class SyntheticMotion:
    """Odometry and gyro errors of the robot."""

    rate_hz: float = 20.0
    """Wheel odometry, reference odometry and IMU rate."""
    radius_scale: tuple[float, float] = (1.02, 0.985)
    track_scale: float = 1.03
    walk_std: float = 0.004
    yaw_walk_std: float = 0.003
    gyro_std: float = 0.006
    gyro_bias: float = 0.015


@dataclass(frozen=True)
class SyntheticRun:
    """The run: timing, room, topics."""

    still_s: float = 3.0
    drive_s: float = 30.0
    speed: float = 0.25
    room: tuple[float, float, float, float] = (-2.0, 6.0, -2.0, 2.5)
    """xmin, xmax, ymin, ymax of the walls, m, odometry frame (robot starts at the origin)."""
    topics: TopicMap = field(default_factory=TopicMap)
    seed: int = 0


def _twist(t: np.ndarray, run: SyntheticRun) -> tuple[np.ndarray, np.ndarray]:
    moving = t >= run.still_s
    v = np.where(moving, run.speed, 0.0)
    w = np.where(moving, 0.3 + 0.4 * np.sin(0.8 * (t - run.still_s)), 0.0)
    return v, w


def _ranges(pose: np.ndarray, angles: np.ndarray, room: tuple[float, ...]) -> np.ndarray:
    """Ranges from the lidar at body pose (x, y, yaw) to the inside of the room's walls."""
    x, y, yaw = pose
    lx = x + LIDAR_MOUNT_XYZ[0] * math.cos(yaw)
    ly = y + LIDAR_MOUNT_XYZ[0] * math.sin(yaw)
    a = angles + yaw
    c, s = np.cos(a), np.sin(a)
    xmin, xmax, ymin, ymax = room
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (xmax - lx) / c, np.where(c < 0, (xmin - lx) / c, np.inf))
        ty = np.where(s > 0, (ymax - ly) / s, np.where(s < 0, (ymin - ly) / s, np.inf))
    return np.minimum(tx, ty)


def _corrupt(
    r: np.ndarray, sector: np.ndarray, lidar: SyntheticLidar, rng: np.random.Generator
) -> np.ndarray:
    n = r.size
    out = r + rng.normal(0.0, lidar.range_std, n)
    out = np.clip(out, lidar.range_min, lidar.range_max)
    phantom = rng.random(n) < lidar.spurious_prob
    out[phantom] = rng.uniform(lidar.spurious_min, lidar.spurious_max, n)[phantom]
    table = np.asarray(lidar.dropout)
    prob = np.where(sector >= 0, table[np.maximum(sector, 0)], table.mean())
    drop = rng.random(n) < prob
    kind = rng.choice(len(KIND_VALUES), size=n, p=lidar.kinds)
    values = np.array([2 * lidar.range_max if v is None else v for v in KIND_VALUES])
    out[drop] = values[kind[drop]]
    return out


def write_calibration_bag(
    path: str | Path,
    lidar: SyntheticLidar = SyntheticLidar(),
    motion: SyntheticMotion = SyntheticMotion(),
    run: SyntheticRun = SyntheticRun(),
) -> dict[str, float]:
    """Write the bag; returns the counts written {"scans": S, "motion_samples": M}."""
    rng = np.random.default_rng(run.seed)
    dt = 1.0 / motion.rate_hz
    n_motion = int(round((run.still_s + run.drive_s) * motion.rate_hz)) + 1
    t = np.arange(n_motion) * dt
    v, w = _twist(t, run)
    truth = np.zeros((n_motion, 3))
    wheel = np.zeros((n_motion, 3))
    sl, sr = motion.radius_scale
    v_l, v_r = v - 0.5 * TRACK * w, v + 0.5 * TRACK * w
    v_odo = 0.5 * (sl * v_l + sr * v_r)
    w_odo = (sr * v_r - sl * v_l) / (TRACK * motion.track_scale)
    walk = rng.normal(0.0, 1.0, (n_motion, 3)) * math.sqrt(dt)
    for k in range(1, n_motion):  # the motion of period k-1 -> k at the period's constant twist
        truth[k] = arc_step(*truth[k - 1], v[k - 1], w[k - 1], dt)
        x, y, yaw = arc_step(*wheel[k - 1], v_odo[k - 1], w_odo[k - 1], dt)
        wheel[k] = (
            x + motion.walk_std * walk[k, 0],
            y + motion.walk_std * walk[k, 1],
            yaw + motion.yaw_walk_std * walk[k, 2],
        )
    # A sample at t_k reports the mean rates of the period that just ended, as the simulator does.
    v_mean = np.concatenate(([0.0], v[:-1]))
    w_mean = np.concatenate(([0.0], w[:-1]))
    gyro = w_mean + motion.gyro_bias + rng.normal(0.0, motion.gyro_std, n_motion)

    fov = math.radians(lidar.fov_deg)
    inc = fov / (lidar.beams - 1)
    angles = -0.5 * fov + inc * np.arange(lidar.beams)
    probe = LaserScan(-0.5 * fov, inc, np.ones(lidar.beams), lidar.range_min, lidar.range_max)
    sector = beam_sectors(probe, Pose2D(), ObservationParams())
    scan_dt = 1.0 / lidar.rate_hz
    n_scans = int((run.still_s + run.drive_s) / scan_dt)
    start_ns = 1_000_000_000
    topics = run.topics
    events: list[tuple[int, int, int]] = [(round(k * dt * 1e9), 0, k) for k in range(n_motion)]
    events += [(round((j + 0.5) * scan_dt * 1e9), 1, j) for j in range(n_scans)]
    with BagRecorder(path, topics=topics) as rec:
        for t_ns, what, k in sorted(events):
            stamp = start_ns + t_ns
            if what == 0:
                x, y, yaw = truth[k]
                rec.write_odometry(stamp, truth[k], (v_mean[k], w_mean[k]))
                rec.write_tf(stamp, truth[k])
                rec.write_odometry(stamp, wheel[k], (v_odo[k - 1] if k else 0.0, w_odo[k - 1] if k else 0.0), wheel=True)  # fmt: skip
                rec.write_imu(stamp, float(gyro[k]))
                continue
            ts = t_ns / 1e9
            i = min(int(ts / dt), n_motion - 2)
            pose = np.array(arc_step(*truth[i], v[i], w[i], ts - i * dt))
            r = _corrupt(_ranges(pose, angles, run.room), sector, lidar, rng)
            scan = LaserScan(-0.5 * fov, inc, r, lidar.range_min, lidar.range_max, stamp)
            rec.write_scan(stamp, quantize_scan(scan))
    return {"scans": n_scans, "motion_samples": n_motion}
