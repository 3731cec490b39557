"""Episode metrics (docs/design/metrics.md#metrics), pure functions of the logged ground-truth trajectory,
and the episode score (docs/design/score.md#score): outcome and time against a reference length."""

from __future__ import annotations

import math
from collections.abc import Callable
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


def body_clearance(
    world: World,
    poses: np.ndarray,
    samples_per_side: int = 6,
    distance: Callable[[World, np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """Distance from Kachaka's body rectangle to the nearest obstacle at each pose.

    poses: (N, 3) x, y, yaw. Returns (N,) m (negative = overlap, +inf without obstacles).
    distance: (world, points (M, 2) m) -> (M,) m, equal to ``World.distance`` (default); the
    episode passes ``world.cylinder_distance.world_distance``, compiled and pruned.
    """
    outline = body_outline(np.asarray(poses).reshape(-1, 3), samples_per_side)
    points = outline.reshape(-1, 2)
    d = world.distance(points) if distance is None else distance(world, points)
    return d.reshape(len(outline), -1).min(axis=1)


SCORE_FORM = "kachaka-v2"
"""Name of the robot form of the score (docs/design/score.md#score); results record it. v2 takes L from
the footprint's shortest route on every world; v1 took BARN's published path on BARN worlds, which
is longer than the route Kachaka drives, so a quarter of BARN's successes sat at the clip (1.0)."""
ROBOT_CLIP = (1.0, 8.0)
"""Robot form: the time is clipped to [1, 8] t_ref, t_ref = L / v_max (the robot's own speed)."""
BARN_SPEED = 2.0
"""BARN's official form: t_opt = L / 2 m/s (Jackal's top speed), m/s."""
BARN_CLIP = (2.0, 8.0)
"""BARN's official form: the time is clipped to [2, 8] t_opt."""


def path_score(
    success: bool, time_s: float, reference_length: float, speed: float, clip: tuple[float, float]
) -> float:
    """BARN's metric in a general form: success x t_ref / clip(t, lo t_ref, hi t_ref).

    time_s: the episode's time, s (>= 0); reference_length: L, m (> 0); speed: the speed
    that makes t_ref = L / speed, m/s (> 0); clip: (lo, hi) multiples of t_ref, 0 < lo <= hi.
    Returns a dimensionless number in [1 / hi, 1 / lo] for a success, 0.0 otherwise.
    ValueError on a non-finite or out-of-range argument.
    """
    lo, hi = clip
    if not (math.isfinite(time_s) and time_s >= 0):
        raise ValueError(f"score: time must be a finite number >= 0 s, got {time_s!r}")
    for name, value in (("reference length", reference_length), ("speed", speed)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"score: {name} must be a finite number > 0, got {value!r}")
    if not 0 < lo <= hi:
        raise ValueError(f"score: clip must hold 0 < lo <= hi, got {clip!r}")
    if not success:
        return 0.0
    t_ref = reference_length / speed
    return t_ref / min(max(time_s, lo * t_ref), hi * t_ref)


def episode_score(success: bool, time_s: float, reference_length: float, v_max: float) -> float:
    """The robot form (``SCORE_FORM``): success x t_ref / clip(t, t_ref, 8 t_ref), t_ref = L /
    v_max. time_s: s; reference_length L: m; v_max: the robot's top translational speed, m/s.
    In [1/8, 1] for a success (1 at or below t_ref: driving L at top speed), 0.0 for a failure."""
    return path_score(success, time_s, reference_length, v_max, ROBOT_CLIP)


def barn_score(success: bool, time_s: float, reference_length: float) -> float:
    """BARN's official form: success x t_opt / clip(t, 2 t_opt, 8 t_opt), t_opt = L / 2 m/s.
    time_s: s; reference_length L: m. In [1/8, 1/2] for a success, 0.0 for a failure."""
    return path_score(success, time_s, reference_length, BARN_SPEED, BARN_CLIP)
