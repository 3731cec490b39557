"""Episode metrics (SPEC section 9), pure functions of the logged ground-truth trajectory."""

from __future__ import annotations

import numpy as np

from .world import BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH, World

OUTCOMES = ("goal", "collision", "timeout")


def trajectory_length(xy: np.ndarray) -> float:
    """TL: summed distance between consecutive positions. xy: (N, 2), m. Returns m."""
    if len(xy) < 2:
        return 0.0
    return float(np.hypot(*np.diff(xy, axis=0).T).sum())


def posture_displacement(yaw: np.ndarray) -> float:
    """PD: accumulated |change of yaw|, with each change wrapped to (-pi, pi]. yaw: (N,), rad."""
    if len(yaw) < 2:
        return 0.0
    d = np.diff(yaw)
    return float(np.abs(np.arctan2(np.sin(d), np.cos(d))).sum())


def body_clearance(world: World, poses: np.ndarray, samples_per_side: int = 6) -> np.ndarray:
    """Distance from Kachaka's body rectangle to the nearest obstacle at each pose.

    poses: (N, 3) x, y, yaw. Returns (N,) m (negative = overlap, +inf without obstacles).
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
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    wx = poses[:, 0:1] + c * local[:, 0] - s * local[:, 1]
    wy = poses[:, 1:2] + s * local[:, 0] + c * local[:, 1]
    d = world.distance(np.column_stack((wx.ravel(), wy.ravel())))
    return d.reshape(len(poses), -1).min(axis=1)
