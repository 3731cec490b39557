"""Episode metrics (docs/design.md#metrics), pure functions of the logged ground-truth trajectory."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from d3dwa_bullet.geometry import body_outline

if TYPE_CHECKING:  # only for the annotation: metrics import no world or simulator module
    from d3dwa_bullet.world.model import World

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
    outline = body_outline(np.asarray(poses).reshape(-1, 3), samples_per_side)
    return world.distance(outline.reshape(-1, 2)).reshape(len(outline), -1).min(axis=1)
