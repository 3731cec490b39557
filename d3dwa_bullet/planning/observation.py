"""The 12-d observation (docs/design/observation.md#observation), one pure function for simulator and bags.

s = [d_g, theta_g, v, w, l_1..l_K]:
  d_g      goal distance clipped at goal_clip, divided by goal_clip        in [0, 1]
  theta_g  body-frame goal bearing / pi                                   in [-1, 1]
  v, w     estimated velocities / their limits                            in [-1, 1]
  l_k      min range of the valid returns in sector k / d_max, clipped    in [0, 1]
Sectors split the field of view (240 deg centred forward) into K equal slices, ordered
from right (-120 deg) to left (+120 deg). Angles and ranges are taken from base_link, not
from the lidar, so scans from any mounting map into the same sectors. A sector with no
valid return reads 1.0.
"""

from __future__ import annotations

import math

import numpy as np

from d3dwa_bullet.params import ObservationParams, RobotLimits
from d3dwa_bullet.sim.scan import check_points

OBSERVATION_LAYOUT = ("d_goal", "theta_goal", "v", "w") + tuple(f"sector_{k}" for k in range(8))


def goal_in_body(pose: np.ndarray | tuple, goal: np.ndarray | tuple) -> np.ndarray:
    """Goal (x, y) in base_link given pose (x, y, yaw) and goal (x, y) in the world: (2,), m."""
    x, y, yaw = (float(v) for v in pose)
    dx, dy = float(goal[0]) - x, float(goal[1]) - y
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * dx + s * dy, -s * dx + c * dy])


def sector_ranges(
    points: np.ndarray, params: ObservationParams = ObservationParams()
) -> np.ndarray:
    """Min distance from base_link of the points in each sector: (K,) float64, m (inf if empty).

    points: (M, 2) float64, metres, body frame (valid returns only).
    """
    pts = check_points(points)
    out = np.full(params.sectors, np.inf)
    if len(pts) == 0:
        return out
    ang = np.arctan2(pts[:, 1], pts[:, 0])
    rng = np.hypot(pts[:, 0], pts[:, 1])
    half = 0.5 * params.fov
    width = params.fov / params.sectors
    inside = (ang >= -half) & (ang <= half)
    idx = np.minimum(((ang[inside] + half) / width).astype(np.intp), params.sectors - 1)
    np.minimum.at(out, idx, rng[inside])
    return out


def build_observation(
    pose: np.ndarray | tuple,
    velocity: np.ndarray | tuple,
    goal: np.ndarray | tuple,
    points: np.ndarray,
    params: ObservationParams = ObservationParams(),
    limits: RobotLimits = RobotLimits(),
) -> np.ndarray:
    """The observation vector: (4 + K,) float64.

    pose: (x, y, yaw) estimate, m/rad, world (odometry) frame.
    velocity: (v, w) estimate, m/s, rad/s.
    goal: (x, y), m, same frame as pose.
    points: (M, 2) valid scan returns, m, base_link frame.
    """
    g = goal_in_body(pose, goal)
    d_goal = min(float(np.hypot(g[0], g[1])), params.goal_clip) / params.goal_clip
    theta = math.atan2(g[1], g[0]) / math.pi
    v, w = (float(u) for u in velocity)
    sectors = np.clip(sector_ranges(points, params) / params.d_max, 0.0, 1.0)
    head = np.array(
        [
            d_goal,
            theta,
            np.clip(v / limits.v_max, -1.0, 1.0),
            np.clip(w / limits.w_max, -1.0, 1.0),
        ]
    )
    return np.concatenate((head, sectors))
