"""Planar geometry shared by the simulator, the estimator, the worlds, bags and metrics.

Pure numpy and ``math``: angle wrapping, the unicycle arc, Kachaka's body outline and
polygon outlines of rectangles and circles. Nothing here knows about worlds, PyBullet or
torch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from d3dwa_bullet.robot import BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH

TAU = 2.0 * math.pi


def wrap_angle(a: float) -> float:
    """Angle wrapped to the interval (-pi, pi], rad.

    Values already in (-pi, pi] are returned bit for bit (a recorded yaw replays unchanged);
    -pi becomes pi. The interval is that of ``math.atan2`` for a positive zero y.
    """
    if -math.pi < a <= math.pi:
        return a
    out = a - TAU * math.ceil((a - math.pi) / TAU)
    # a within rounding of an odd multiple of pi can land one turn off: bring it in
    if out > math.pi:
        out -= TAU
    elif out <= -math.pi:
        out += TAU
    return out


def wrap_angle_modular(a: float) -> float:
    """Angle reduced into [-pi, pi) as ``(a + pi) % 2 pi - pi``, rad: pi becomes -pi.

    Not the same numbers as :func:`wrap_angle`: adding pi re-rounds every value, in range
    or not (by up to ~2e-16 rad; 1e-20 becomes 0). The simulator keeps the yaw of its wheel
    odometry, EKF, gyro rate and pose fix with it, and a noisy episode feeds that estimate
    back into its own control: with any other rounding every seeded noisy episode would
    take another path (not a worse one, but not the one it took). Use :func:`wrap_angle`
    everywhere else.
    """
    return (a + math.pi) % TAU - math.pi


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """Vectorised :func:`wrap_angle`: (N,) rad -> (N,) float64 in (-pi, pi], the same values."""
    a = np.asarray(a, dtype=np.float64)
    inside = (a > -np.pi) & (a <= np.pi)
    out = np.where(inside, a, a - TAU * np.ceil((a - np.pi) / TAU))
    out = np.where(out > np.pi, out - TAU, out)
    return np.where(out <= -np.pi, out + TAU, out)


def arc_step(
    x: float, y: float, yaw: float, v: float, w: float, dt: float
) -> tuple[float, float, float]:
    """Exact unicycle motion under constant (v, w) for dt seconds; returns (x, y, yaw).

    x, y: m; yaw: rad (not wrapped); v: m/s; w: rad/s; dt: s. Uses the chord form
    ``c = v dt sinc(w dt / 2)`` along the mid-arc heading, which is exact for any w and
    smooth through w = 0 (straight line).
    """
    half = 0.5 * w * dt
    chord = v * dt * (math.sin(half) / half if abs(half) > 1e-9 else 1.0 - half * half / 6.0)
    mid = yaw + half
    return x + chord * math.cos(mid), y + chord * math.sin(mid), yaw + w * dt


def body_outline(poses: Sequence[float] | np.ndarray, samples_per_side: int = 8) -> np.ndarray:
    """Points on Kachaka's body rectangle at one pose (x, y, yaw) or at (N, 3) poses.

    The rectangle is the body box of :mod:`d3dwa_bullet.robot` seen from above, sampled
    with ``samples_per_side`` points per side starting at each corner. Returns
    (4 * samples, 2) for one pose or (N, 4 * samples, 2) for N poses, m, world frame.
    """
    t = np.linspace(-1.0, 1.0, samples_per_side, endpoint=False)
    hl, hw = BODY_HALF_LENGTH, BODY_HALF_WIDTH
    local = np.concatenate(
        [
            np.column_stack((hl * t, np.full_like(t, -hw))),
            np.column_stack((np.full_like(t, hl), hw * t)),
            np.column_stack((-hl * t, np.full_like(t, hw))),
            np.column_stack((np.full_like(t, -hl), -hw * t)),
        ]
    )
    local[:, 0] += BODY_CENTER_X
    arr = np.asarray(poses, dtype=np.float64)
    many = arr.reshape(-1, 3)
    c, s = np.cos(many[:, 2])[:, None], np.sin(many[:, 2])[:, None]
    wx = many[:, 0:1] + c * local[:, 0] - s * local[:, 1]
    wy = many[:, 1:2] + s * local[:, 0] + c * local[:, 1]
    out = np.stack((wx, wy), axis=-1)
    return out[0] if arr.ndim == 1 else out


def rectangle_corners(center: Sequence[float], size: Sequence[float], yaw: float) -> np.ndarray:
    """Corners of a rectangle, (4, 2) float64, m, counter-clockwise from (-x, -y) of its frame.

    center (x, y) m and yaw rad of the rectangle's frame; size (sx, sy) m along its axes.
    """
    hx, hy = 0.5 * size[0], 0.5 * size[1]
    local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
    c, s = math.cos(yaw), math.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(center)


def circle_polygon(center: Sequence[float], radius: float, segments: int) -> np.ndarray:
    """Regular polygon inscribed in a circle, (segments, 2) float64, m, counter-clockwise
    from the +x direction. Its sides stay within ``radius (1 - cos(pi / segments))`` of the
    circle."""
    a = 2 * np.pi * np.arange(segments) / segments
    return np.column_stack((center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)))


def body_clearance_to_points(points: np.ndarray) -> float:
    """Smallest distance from Kachaka's body box to points, m: 0 for a point inside the box,
    inf when there is none. points: (M, 2) float64, m, base_link (the box is axis-aligned
    there)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if pts.size == 0:
        return math.inf
    dx = np.maximum(np.abs(pts[:, 0] - BODY_CENTER_X) - BODY_HALF_LENGTH, 0.0)
    dy = np.maximum(np.abs(pts[:, 1]) - BODY_HALF_WIDTH, 0.0)
    return float(np.hypot(dx, dy).min())
