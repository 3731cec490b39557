"""Worlds on a grid: clearance fields and occupancy.

Pure functions over a :class:`~d3dwa_bullet.world.model.World`, no simulator. The fields
here are what :mod:`~d3dwa_bullet.world.routes` (shortest paths) and
:mod:`~d3dwa_bullet.world.reachability` (the planner's footprint) search.

Grid convention: ``values[i, j]`` is the cell whose centre is at
``(origin[0] + j * resolution, origin[1] + i * resolution)``: row index grows with y (unlike
an image). The origin is a multiple of the resolution, so whole-metre points such as the
start (0, 0) fall on cell centres.

Passability is judged for a circle about base_link that must keep its centre farther than
the planner's r + m (0.20 m, ``DEFAULT_INFLATION``) from every obstacle: obstacles are
inflated by r + m and the robot becomes a point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.world.model import World, obstacle_distance, obstacle_extent

DEFAULT_RESOLUTION = 0.02
"""Cell size of the path-length grid, m."""
DEFAULT_INFLATION = PlannerParams().admissible_clearance
"""Obstacle inflation for a point robot at base_link: the planner's r + m, m."""
DEFAULT_MARGIN = 1.0
"""Free border around the world's bounds, so open worlds can be bypassed on the outside, m."""
FIELD_CAP = 1.0
"""Clearance values are exact up to this distance and capped there, m (> inflation + ROUTE_TUBE)."""


@dataclass(frozen=True)
class Grid:
    """A 2-D field on a regular grid.

    values: (ny, nx) array; cell (i, j) is centred at (origin[0] + j*res, origin[1] + i*res), m.
    """

    values: np.ndarray
    origin: tuple[float, float]
    resolution: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.values.shape  # type: ignore[return-value]

    def centers(self) -> np.ndarray:
        """Cell centres, (ny, nx, 2) float64, m, world frame."""
        ny, nx = self.shape
        xs = self.origin[0] + self.resolution * np.arange(nx)
        ys = self.origin[1] + self.resolution * np.arange(ny)
        gx, gy = np.meshgrid(xs, ys)
        return np.stack((gx, gy), axis=-1)

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """Nearest cell (i, j) of points (N, 2) m: (N, 2) int64, clipped into the grid."""
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        j = np.rint((pts[:, 0] - self.origin[0]) / self.resolution).astype(np.int64)
        i = np.rint((pts[:, 1] - self.origin[1]) / self.resolution).astype(np.int64)
        ny, nx = self.shape
        return np.column_stack((np.clip(i, 0, ny - 1), np.clip(j, 0, nx - 1)))

    def point_of(self, cells: np.ndarray) -> np.ndarray:
        """Centres (N, 2) m of cells (N, 2) given as (i, j)."""
        c = np.atleast_2d(np.asarray(cells))
        return np.column_stack(
            (
                self.origin[0] + self.resolution * c[:, 1],
                self.origin[1] + self.resolution * c[:, 0],
            )
        )

    def sample(self, points: np.ndarray) -> np.ndarray:
        """Bilinear interpolation of the field at points (N, 2) m: (N,) float64.

        Points outside the grid take the nearest edge value.
        """
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        coords = np.vstack(
            (
                (pts[:, 1] - self.origin[1]) / self.resolution,
                (pts[:, 0] - self.origin[0]) / self.resolution,
            )
        )
        return ndimage.map_coordinates(
            np.asarray(self.values, dtype=np.float64), coords, order=1, mode="nearest"
        )


def grid_frame(
    world: World, resolution: float = DEFAULT_RESOLUTION, margin: float = DEFAULT_MARGIN
) -> tuple[tuple[float, float], tuple[int, int]]:
    """Origin (cell (0, 0) centre, m) and shape (ny, nx) of a grid covering the world."""
    if not resolution > 0:
        raise ValueError(f"grid resolution must be > 0, got {resolution!r}")
    xmin, ymin, xmax, ymax = world.bounds(margin)
    i0, j0 = math.floor(ymin / resolution), math.floor(xmin / resolution)
    i1, j1 = math.ceil(ymax / resolution), math.ceil(xmax / resolution)
    return (j0 * resolution, i0 * resolution), (i1 - i0 + 1, j1 - j0 + 1)


def clearance_field(
    world: World,
    resolution: float = DEFAULT_RESOLUTION,
    margin: float = DEFAULT_MARGIN,
    cap: float = FIELD_CAP,
) -> Grid:
    """Signed distance from each cell centre to the nearest obstacle surface, m.

    Exact (negative inside obstacles) up to ``cap`` and capped there. Each obstacle is
    evaluated only on the cells of its bounding box grown by ``cap``, so maps with
    thousands of small boxes stay cheap.
    """
    origin, (ny, nx) = grid_frame(world, resolution, margin)
    values = np.full((ny, nx), cap, dtype=np.float64)
    for ob in world.obstacles:
        ex, ey = obstacle_extent(ob)
        cx, cy = ob.center
        j0 = max(0, math.floor((cx - ex - cap - origin[0]) / resolution))
        j1 = min(nx, math.ceil((cx + ex + cap - origin[0]) / resolution) + 1)
        i0 = max(0, math.floor((cy - ey - cap - origin[1]) / resolution))
        i1 = min(ny, math.ceil((cy + ey + cap - origin[1]) / resolution) + 1)
        if j0 >= j1 or i0 >= i1:
            continue
        xs = origin[0] + resolution * np.arange(j0, j1)
        ys = origin[1] + resolution * np.arange(i0, i1)
        gx, gy = np.meshgrid(xs, ys)
        d = obstacle_distance(ob, np.column_stack((gx.ravel(), gy.ravel())))
        window = values[i0:i1, j0:j1]
        np.minimum(window, d.reshape(window.shape), out=window)
    return Grid(values=values, origin=origin, resolution=resolution)


def rasterize(
    world: World, resolution: float = DEFAULT_RESOLUTION, margin: float = DEFAULT_MARGIN
) -> Grid:
    """Occupancy of the world: (ny, nx) bool, True where a cell centre is inside an obstacle."""
    field = clearance_field(world, resolution, margin, cap=2 * resolution)
    return Grid(values=field.values <= 0.0, origin=field.origin, resolution=resolution)
