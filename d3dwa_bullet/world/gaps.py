"""Gaps between obstacles: the exact free distance of a pair, and the passages of a world.

Pure functions over obstacles and a :class:`~d3dwa_bullet.world.model.World`. The layout
generator keeps obstacles either clearly apart or closed up with :func:`gap_between`;
the world checks look for passages that look open but are too narrow with :func:`passages`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from d3dwa_bullet.geometry import rectangle_corners
from d3dwa_bullet.world.model import Cylinder, Obstacle, World, obstacle_distance, obstacle_extent

OUTLINE_SAMPLES = 256
"""Points per obstacle outline when looking for passages between obstacles."""


def boundary_points(ob: Obstacle, samples: int = OUTLINE_SAMPLES) -> np.ndarray:
    """Points on an obstacle's footprint boundary, (samples, 2) float64, m, world frame.

    A box gets samples // 4 points per side, starting at each corner.
    """
    if isinstance(ob, Cylinder):
        a = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
        return np.asarray(ob.center) + ob.radius * np.column_stack((np.cos(a), np.sin(a)))
    hx, hy = 0.5 * ob.size[0], 0.5 * ob.size[1]
    corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
    t = np.linspace(0.0, 1.0, max(1, samples // 4), endpoint=False)[:, None]
    local = np.concatenate(
        [c + t * (np.roll(corners, -1, axis=0)[k] - c) for k, c in enumerate(corners)]
    )
    c, s = math.cos(ob.yaw), math.sin(ob.yaw)
    return np.asarray(ob.center) + local @ np.array([[c, s], [-s, c]])


def _boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test for two rectangles given by their corners (4, 2)."""
    for poly in (a, b):
        for k in range(2):
            edge = poly[k + 1] - poly[k]
            axis = np.array([-edge[1], edge[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def gap_between(a: Obstacle, b: Obstacle) -> float:
    """Free distance between two obstacle footprints, m (<= 0 if they touch or overlap).

    Exact: between two disjoint convex polygons the closest pair always includes a
    corner of one of them, and a cylinder is its centre grown by the radius.
    """
    if isinstance(a, Cylinder) and isinstance(b, Cylinder):
        return math.dist(a.center, b.center) - a.radius - b.radius
    if isinstance(a, Cylinder):
        return float(obstacle_distance(b, np.array([a.center]))[0]) - a.radius
    if isinstance(b, Cylinder):
        return float(obstacle_distance(a, np.array([b.center]))[0]) - b.radius
    ca = rectangle_corners(a.center, a.size, a.yaw)
    cb = rectangle_corners(b.center, b.size, b.yaw)
    d = float(min(obstacle_distance(b, ca).min(), obstacle_distance(a, cb).min()))
    return min(d, 0.0) if _boxes_overlap(ca, cb) else d


class Passage(NamedTuple):
    """The free gap between two obstacles, with nothing else in it."""

    first: int
    """Index of one obstacle in world.obstacles."""
    second: int
    """Index of the other."""
    width: float
    """Free distance between them, m."""
    midpoint: tuple[float, float]
    """Middle of their closest approach, m, world frame."""


def passages(world: World, max_width: float = 1.0, samples: int = OUTLINE_SAMPLES) -> list[Passage]:
    """Gaps in (0, max_width) between pairs of obstacles that no third obstacle obstructs.

    A pair counts when the middle of its closest approach is about ``width / 2`` from every
    obstacle, so two beds in rooms on either side of a wall do not form a passage. Sorted
    by width, narrowest first. Widths are exact to about the outline sample spacing.
    """
    obs = world.obstacles
    rims = [boundary_points(ob, samples) for ob in obs]
    reach = [float(np.hypot(*obstacle_extent(ob))) for ob in obs]
    found = []
    for i in range(len(obs)):
        for j in range(i + 1, len(obs)):
            if math.dist(obs[i].center, obs[j].center) - reach[i] - reach[j] >= max_width:
                continue
            d_ij, d_ji = obstacle_distance(obs[j], rims[i]), obstacle_distance(obs[i], rims[j])
            if d_ij.min() <= d_ji.min():
                p, other_rim = rims[i][np.argmin(d_ij)], rims[j]
            else:
                p, other_rim = rims[j][np.argmin(d_ji)], rims[i]
            width = float(min(d_ij.min(), d_ji.min()))
            if not 0.0 < width < max_width:
                continue
            q = other_rim[np.argmin(np.hypot(*(other_rim - p).T))]
            spacing = float(np.hypot(*np.diff(other_rim, axis=0).T).max())
            mid = 0.5 * (p + q)
            if float(world.distance(mid[None])[0]) >= 0.5 * width - spacing:
                found.append(Passage(i, j, width, (float(mid[0]), float(mid[1]))))
    return sorted(found, key=lambda g: g.width)
