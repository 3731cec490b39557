"""Distance from many points to the nearest of many cylinders, compiled (numba) and pruned.

The episode's clearance metric measures Kachaka's body outline (24 points a pose) at every pose
against every cylinder: on BARN, hundreds of cylinders and thousands of poses, 50-340 ms an
episode as a loop over cylinders in numpy (docs/design/episode-cost.md). Here the cylinders are
sorted by x once, and each point walks outward from its own x until no cylinder further away
along x can be nearer than the best found: ``|dx| - r_max`` bounds ``hypot(dx, dy) - r`` from
below. Each distance a point keeps is the same ``hypot(px - cx, py - cy) - r`` in float64 as
``world.model.obstacle_distance``'s, so the minimum is the same bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from d3dwa_bullet.world.model import Box, Cylinder, World, obstacle_distance

PRUNE_SLACK = 1e-9
"""m added to the pruning bound, so a rounding in ``|dx| - r_max`` never drops the nearest."""


@njit(cache=True)
def _nearest(
    px: np.ndarray, py: np.ndarray, cx: np.ndarray, cy: np.ndarray, r: np.ndarray
) -> np.ndarray:
    n, m = px.shape[0], cx.shape[0]
    r_max = r.max()
    out = np.empty(n)
    for i in range(n):
        x, y = px[i], py[i]
        k = np.searchsorted(cx, x)
        best = math.inf
        lo, hi = k - 1, k
        while lo >= 0 or hi < m:
            if hi < m:
                dx = cx[hi] - x
                if dx - r_max > best + PRUNE_SLACK:
                    hi = m
                else:
                    d = math.hypot(x - cx[hi], y - cy[hi]) - r[hi]
                    best = min(best, d)
                    hi += 1
            if lo >= 0:
                dx = x - cx[lo]
                if dx - r_max > best + PRUNE_SLACK:
                    lo = -1
                else:
                    d = math.hypot(x - cx[lo], y - cy[lo]) - r[lo]
                    best = min(best, d)
                    lo -= 1
        out[i] = best
    return out


class CylinderIndex:
    """Cylinders sorted by centre x for :meth:`nearest`: centres (M, 2) m, radii (M,) m."""

    def __init__(self, centres: np.ndarray, radii: np.ndarray) -> None:
        order = np.argsort(centres[:, 0], kind="stable")
        self._x = np.ascontiguousarray(centres[order, 0], dtype=np.float64)
        self._y = np.ascontiguousarray(centres[order, 1], dtype=np.float64)
        self._r = np.ascontiguousarray(radii[order], dtype=np.float64)

    def __len__(self) -> int:
        return len(self._r)

    def nearest(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (N,) m from points (N, 2) m to the nearest cylinder's surface (+inf
        without cylinders)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if not len(self._r):
            return np.full(len(pts), np.inf)
        return _nearest(
            np.ascontiguousarray(pts[:, 0]),
            np.ascontiguousarray(pts[:, 1]),
            self._x,
            self._y,
            self._r,
        )


def world_distance(world: World, points: np.ndarray) -> np.ndarray:
    """:meth:`World.distance` of many points, the cylinders through a ``CylinderIndex``, the
    boxes one by one as it measures them: points (N, 2) m; (N,) m, the same bit for bit."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    cylinders = [ob for ob in world.obstacles if isinstance(ob, Cylinder)]
    centres = np.array([ob.center for ob in cylinders], dtype=np.float64).reshape(-1, 2)
    best = CylinderIndex(
        centres, np.array([ob.radius for ob in cylinders], dtype=np.float64)
    ).nearest(pts)
    for ob in world.obstacles:
        if isinstance(ob, Box):
            best = np.minimum(best, obstacle_distance(ob, pts))
    return best
