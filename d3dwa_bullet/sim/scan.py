"""The LaserScan record shared by the simulator and recorded bags, and its REP-117 cleaning.

REP-117: ``+inf`` = no return within range, ``-inf`` = too close, ``NaN`` = invalid.
Real drivers also emit ``0.0`` or values outside ``[range_min, range_max]`` for "no
return"; all of those are *invalid* here, never obstacles at 0 m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.errors import ScanError


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: x, y in metres, yaw in radians (REP-103)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class LaserScan:
    """A LaserScan-like record (sensor_msgs/LaserScan semantics).

    ranges: (N,) float64, metres, beam i at angle ``angle_min + i * angle_increment``
    in the lidar frame. ``stamp_ns`` is an integer time in nanoseconds.
    """

    angle_min: float
    angle_increment: float
    ranges: np.ndarray
    range_min: float
    range_max: float
    stamp_ns: int = 0

    def __post_init__(self) -> None:
        ranges = np.asarray(self.ranges, dtype=np.float64)
        if ranges.ndim != 1 or ranges.size == 0:
            raise ScanError(
                f"LaserScan.ranges must be a non-empty 1-D array, got shape {ranges.shape}"
            )
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            if not np.isfinite(getattr(self, name)):
                raise ScanError(f"LaserScan.{name} must be finite, got {getattr(self, name)!r}")
        if self.angle_increment == 0:
            raise ScanError("LaserScan.angle_increment must be non-zero, got 0.0")
        if not 0 <= self.range_min < self.range_max:
            raise ScanError(
                f"LaserScan needs 0 <= range_min < range_max, got {self.range_min!r}, {self.range_max!r}"
            )
        object.__setattr__(self, "ranges", ranges)

    @property
    def angles(self) -> np.ndarray:
        """Beam angles, (N,) float64, rad, lidar frame."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size)

    def valid_mask(self) -> np.ndarray:
        """(N,) bool: beams that returned a usable range (finite, > 0, within limits)."""
        r = self.ranges
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r > 0.0) & (r >= self.range_min) & (r <= self.range_max)


def scan_points_body(scan: LaserScan, mount: Pose2D) -> np.ndarray:
    """Valid returns as points in base_link.

    mount: the lidar frame's pose in base_link. Returns (M, 2) float64, metres, body frame.
    """
    valid = scan.valid_mask()
    r = scan.ranges[valid]
    a = scan.angles[valid] + mount.yaw
    return np.column_stack((mount.x + r * np.cos(a), mount.y + r * np.sin(a)))


def check_points(points: np.ndarray, what: str = "points") -> np.ndarray:
    """Validate an (M, 2) array of scan points; NaN or inf is a caller bug, not a reading."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ScanError(f"{what} must have shape (M, 2), got {pts.shape}")
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ScanError(
            f"{what}[{i}] = {pts[i].tolist()} is not finite; filter invalid beams "
            "(NaN/inf/0) with LaserScan.valid_mask() before planning"
        )
    return pts
