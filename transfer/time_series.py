"""A bag's streams as numpy time series on the replay clock, and their alignment to scans.

Alignment: odometry is linearly interpolated to scan times (yaw through the shortest
angular difference, i.e. unwrapped, then wrapped to (-pi, pi]); a scan before the first or
after the last odometry sample has no pose and is skipped by the replay with that reason.
At a scan time equal to an odometry stamp the odometry values are returned bit for bit.
Headerless samples (commands, planner parameters) are matched to the nearest sample in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.geometry import wrap_angles


@dataclass(frozen=True)
class OdometrySeries:
    """nav_msgs/Odometry as arrays, sorted by time, one sample per distinct stamp.

    t_ns: (N,) int64 ns (replay clock); x, y: m; yaw: rad in (-pi, pi]; v: m/s (twist
    linear.x); w: rad/s (twist angular.z). Pose in ``frame_id``, twist in ``child_frame_id``.
    """

    t_ns: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray
    w: np.ndarray
    frame_id: str = ""
    child_frame_id: str = ""

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def at(self, t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Interpolate to query times.

        Returns pose (M, 3) [x, y, yaw], twist (M, 2) [v, w], and where (M,) int8:
        -1 before the first sample, 0 covered, +1 after the last sample (pose and twist
        hold the nearest end sample there; the replay skips those scans).
        """
        t_q = np.asarray(t_ns, dtype=np.int64)
        i, j, frac = _bracket(self.t_ns, t_q)
        cols = [_lerp(a, i, j, frac) for a in (self.x, self.y)]
        yaw = wrap_angles(self.yaw[i] + frac * wrap_angles(self.yaw[j] - self.yaw[i]))
        twist = [_lerp(a, i, j, frac) for a in (self.v, self.w)]
        where = np.where(t_q < self.t_ns[0], -1, np.where(t_q > self.t_ns[-1], 1, 0))
        return np.column_stack((*cols, yaw)), np.column_stack(twist), where.astype(np.int8)


@dataclass(frozen=True)
class ImuSeries:
    """Gyro yaw rate: t_ns (N,) int64 ns, w_z (N,) rad/s about the base z axis."""

    t_ns: np.ndarray
    w_z: np.ndarray
    frame_id: str = ""

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def at(self, t_ns: np.ndarray) -> np.ndarray:
        """(M,) rad/s interpolated to query times; NaN outside the recorded span."""
        t_q = np.asarray(t_ns, dtype=np.int64)
        i, j, frac = _bracket(self.t_ns, t_q)
        out = _lerp(self.w_z, i, j, frac)
        return np.where((t_q < self.t_ns[0]) | (t_q > self.t_ns[-1]), np.nan, out)


@dataclass(frozen=True)
class TimedValues:
    """Headerless samples: t_ns (N,) int64 ns, values (N, k) float64."""

    t_ns: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def nearest(self, t_ns: np.ndarray, max_gap_ns: int) -> np.ndarray:
        """(M, k): the sample nearest in time to each query, NaN if none within max_gap_ns."""
        t_q = np.asarray(t_ns, dtype=np.int64)
        k = self.values.shape[1]
        if len(self) == 0:
            return np.full((t_q.size, k), np.nan)
        hi = np.clip(np.searchsorted(self.t_ns, t_q), 0, len(self) - 1)
        lo = np.clip(hi - 1, 0, len(self) - 1)
        pick = np.where(np.abs(self.t_ns[lo] - t_q) <= np.abs(self.t_ns[hi] - t_q), lo, hi)
        out = self.values[pick].astype(np.float64)
        out[np.abs(self.t_ns[pick] - t_q) > max_gap_ns] = np.nan
        return out


@dataclass(frozen=True)
class Goal:
    """A goal pose from geometry_msgs/PoseStamped: (x, y) m and yaw rad in frame_id."""

    t_ns: int
    x: float
    y: float
    yaw: float
    frame_id: str


def _bracket(t_src: np.ndarray, t_q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices i <= j around each query and the fraction in [0, 1] between them."""
    n = t_src.size
    i = np.clip(np.searchsorted(t_src, t_q, side="right") - 1, 0, n - 1)
    j = np.minimum(i + 1, n - 1)
    span = (t_src[j] - t_src[i]).astype(np.float64)
    offset = (t_q - t_src[i]).astype(np.float64)
    frac = np.divide(offset, span, out=np.zeros_like(span), where=span > 0)
    return i, j, np.clip(frac, 0.0, 1.0)


def _lerp(a: np.ndarray, i: np.ndarray, j: np.ndarray, frac: np.ndarray) -> np.ndarray:
    # a[i] + 0 * (...) keeps knot values bit-exact.
    return a[i] + frac * (a[j] - a[i])
