"""Shortest routes through a world: start to goal, and every cell to the goal.

Pure functions over a :class:`~d3dwa_bullet.world.model.World` and its
:func:`~d3dwa_bullet.world.grid.clearance_field`, no simulator. Used to check that a world
is passable and how long its shortest route is (``tools/experiments/check_worlds.py``), to
reject impassable generated layouts, for route starts, by the oracle's route field, and for the
length L of the episode score (:func:`reference_length`, docs/design/score.md#score).
Obstacles are inflated by the planner's r + m and the robot is a point at base_link
(:mod:`~d3dwa_bullet.world.grid`).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.world.grid import (
    DEFAULT_INFLATION,
    DEFAULT_MARGIN,
    DEFAULT_RESOLUTION,
    Grid,
    clearance_field,
)
from d3dwa_bullet.world.model import World

ROUTE_TUBE = 0.5
"""Half-width of the tube around the shortest path in which its bottleneck is measured, m."""
ENDPOINT_RADIUS = 0.25
"""Around start and goal the bottleneck is not measured (their own clearance is no passage), m."""

#: The "path length" column of docs/worlds.md (TL of the best method), m: design targets.
REFERENCE_PATH_LENGTHS: dict[str, float] = {
    "TS1": 3.6,
    "TS2": 7.0,
    "TS3": 4.25,
    "TS4": 9.7,
    "US1": 5.0,
    "H1": 6.0,
    "H2": 5.1,
    "H3": 10.0,
    "R1": 3.0,
    "R2": 3.0,
    "R3": 4.5,
}


class ShortestPath(NamedTuple):
    """The shortest inflated route from a world's start to its goal."""

    points: np.ndarray
    """Vertices of the smoothed path, (N, 2) float64, m, start first, goal last."""
    length: float
    """Length of the smoothed (any-angle) path, m."""
    grid_length: float
    """Length of the 8-connected grid path before smoothing (up to ~8 % longer), m."""
    min_clearance: float
    """Smallest obstacle distance along the smoothed path, m (>= the inflation)."""
    bottleneck: float
    """Largest clearance a route near this path can keep through its tightest spot, m.

    About half the width of the narrowest gap the route passes, capped at inflation +
    ROUTE_TUBE in open space. A gap of width g needs g / 2 > inflation to be passable."""


def _grid_graph(free: np.ndarray, resolution: float) -> csr_matrix:
    """8-connected graph over the free cells of a (ny, nx) mask, both directions, edge weights m."""
    ny, nx = free.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    src, dst, wts = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = (slice(0, ny - di), slice(max(0, -dj), nx - max(0, dj)))
        b = (slice(di, ny), slice(max(0, dj), nx - max(0, -dj)))
        both = free[a] & free[b]
        ia, ib = idx[a][both], idx[b][both]
        src += [ia, ib]
        dst += [ib, ia]
        wts += 2 * [np.full(ia.size, resolution * math.hypot(di, dj))]
    s, d, w = np.concatenate(src), np.concatenate(dst), np.concatenate(wts)
    return csr_matrix((w, (s, d)), shape=(ny * nx, ny * nx))


def _segment_clear(field: Grid, a: np.ndarray, b: np.ndarray, inflation: float) -> bool:
    n = max(2, math.ceil(float(np.hypot(*(b - a))) / (0.5 * field.resolution)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return bool((field.sample(a + t * (b - a)) > inflation).all())


def _smooth(field: Grid, pts: np.ndarray, inflation: float) -> np.ndarray:
    """Greedy line-of-sight shortcutting of a grid path (N, 2) -> (M, 2), M <= N.

    From each anchor, the farthest visible path point is found by doubling the look-ahead
    and then bisecting, so a path of N points costs O(corners * log N) segment checks.
    """
    out = [pts[0]]
    i, n = 0, len(pts)
    while i < n - 1:
        good, step = i + 1, 1
        while good + step < n and _segment_clear(field, pts[i], pts[good + step], inflation):
            good += step
            step *= 2
        bad = min(good + step, n)
        while bad - good > 1:
            mid = (good + bad) // 2
            good, bad = (
                (mid, bad) if _segment_clear(field, pts[i], pts[mid], inflation) else (good, mid)
            )
        out.append(pts[good])
        i = good
    return np.asarray(out)


def _route_bottleneck(
    field: Grid, path_cells: np.ndarray, start: np.ndarray, goal: np.ndarray, inflation: float
) -> float:
    """Maximin clearance between start and goal inside a tube around the path, m."""
    res = field.resolution
    # work on the window the tube can reach
    m = math.ceil(ROUTE_TUBE / res) + 1
    ny, nx = field.shape
    i0, j0 = max(0, path_cells[:, 0].min() - m), max(0, path_cells[:, 1].min() - m)
    i1, j1 = min(ny, path_cells[:, 0].max() + m + 1), min(nx, path_cells[:, 1].max() + m + 1)
    values = field.values[i0:i1, j0:j1]
    on_path = np.zeros(values.shape, dtype=bool)
    on_path[path_cells[:, 0] - i0, path_cells[:, 1] - j0] = True
    tube = ndimage.distance_transform_edt(~on_path) * res <= ROUTE_TUBE
    centers = field.centers()[i0:i1, j0:j1]
    near_end = (np.hypot(*(centers - start).transpose(2, 0, 1)) <= ENDPOINT_RADIUS) | (
        np.hypot(*(centers - goal).transpose(2, 0, 1)) <= ENDPOINT_RADIUS
    )
    (si, sj), (gi, gj) = field.cell_of(np.array([start, goal])) - np.array([i0, j0])

    def connected(t: float) -> bool:
        labels, _ = ndimage.label(tube & ((values > t) | near_end))
        return labels[si, sj] != 0 and labels[si, sj] == labels[gi, gj]

    lo, hi = inflation, inflation + ROUTE_TUBE
    if connected(hi):
        return hi
    while hi - lo > 0.25 * res:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if connected(mid) else (lo, mid)
    return lo


def shortest_path(
    world: World,
    resolution: float = DEFAULT_RESOLUTION,
    inflation: float = DEFAULT_INFLATION,
    margin: float = DEFAULT_MARGIN,
    field: Grid | None = None,
) -> ShortestPath:
    """Shortest route for base_link from start to goal with obstacles inflated by ``inflation``.

    8-connected Dijkstra on the grid, then line-of-sight smoothing. Raises
    WorldFormatError if the start or goal is within ``inflation`` of an obstacle or no
    route exists. ``field`` reuses a precomputed :func:`clearance_field`.
    """
    if field is None:
        field = clearance_field(world, resolution, margin)
    start = np.array(world.start[:2], dtype=np.float64)
    goal = np.array(world.goal, dtype=np.float64)
    for name, p in (("start", start), ("goal", goal)):
        d = float(world.distance(p[None])[0])
        if not d > inflation:
            raise WorldFormatError(
                f"{world.source}: field '{name}' = {p.tolist()} is {d:.3f} m from an obstacle; "
                f"the planner needs > {inflation:.2f} m"
            )
    free = field.values > inflation
    (si, sj), (gi, gj) = field.cell_of(np.array([start, goal]))
    free[si, sj] = free[gi, gj] = True  # their exact clearance was checked above
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    if labels[si, sj] != labels[gi, gj]:
        raise WorldFormatError(
            f"{world.source}: no collision-free route from start {list(world.start)} to goal "
            f"{list(world.goal)} with obstacles inflated by {inflation:.2f} m"
        )
    # search only the bounding box of the start's free component
    rows, cols = np.nonzero(labels == labels[si, sj])
    i0, j0 = rows.min(), cols.min()
    sub = labels[i0 : rows.max() + 1, j0 : cols.max() + 1] == labels[si, sj]
    nx = sub.shape[1]
    s_id, g_id = (si - i0) * nx + (sj - j0), (gi - i0) * nx + (gj - j0)
    _, pred = dijkstra(
        _grid_graph(sub, field.resolution), directed=True, indices=s_id, return_predecessors=True
    )
    ids = [g_id]
    while ids[-1] != s_id:
        ids.append(int(pred[ids[-1]]))
    ids.reverse()
    cells = np.column_stack(np.divmod(np.asarray(ids), nx)) + np.array([i0, j0])
    pts = field.point_of(cells)
    pts[0], pts[-1] = start, goal
    grid_len = float(np.hypot(*np.diff(pts, axis=0).T).sum())
    smooth = _smooth(field, pts, inflation)
    length = float(np.hypot(*np.diff(smooth, axis=0).T).sum())
    dense = np.concatenate(
        [
            a
            + np.linspace(0, 1, max(2, math.ceil(np.hypot(*(b - a)) / resolution)))[:, None]
            * (b - a)
            for a, b in zip(smooth[:-1], smooth[1:], strict=True)
        ]
    )
    return ShortestPath(
        points=smooth,
        length=length,
        grid_length=grid_len,
        min_clearance=float(world.distance(dense).min()) if world.obstacles else math.inf,
        bottleneck=_route_bottleneck(field, cells, start, goal, inflation),
    )


def geodesic_field(
    world: World,
    resolution: float = DEFAULT_RESOLUTION,
    inflation: float = DEFAULT_INFLATION,
    margin: float = DEFAULT_MARGIN,
) -> Grid:
    """Length of the shortest route from every cell to the goal, m (inf where the cell is
    blocked or cut off), with obstacles inflated by ``inflation``: 8-connected Dijkstra from
    the goal cell, which counts as free. Privileged map knowledge: for diagnostics such as
    :mod:`tools.experiments.oracle`, never for the observation."""
    field = clearance_field(world, resolution, margin)
    free = field.values > inflation
    gi, gj = field.cell_of(np.array([world.goal], dtype=np.float64))[0]
    free[gi, gj] = True
    dist = dijkstra(_grid_graph(free, resolution), directed=True, indices=gi * free.shape[1] + gj)
    dist = dist.reshape(free.shape)
    dist[~free] = np.inf
    return Grid(values=dist, origin=field.origin, resolution=resolution)


@functools.lru_cache(maxsize=1024)
def reference_length(world: World) -> float:
    """L of the robot form of the episode score (docs/design/score.md#score), m: the length of
    :func:`shortest_path` (base_link as a point, obstacles inflated by the planner's r + m),
    on every world, BARN's included (its published path, :func:`official_length`, is a grid
    path up to 3.6 m longer than the route the robot can drive);
    where no such route exists (start or goal within r + m of an obstacle, or every gap
    narrower than 2 (r + m)), the straight line from start to goal, a lower bound of any path.
    Never below one grid cell (``DEFAULT_RESOLUTION``), so a start on the goal has a t_ref.

    Cached per world (a route costs ~0.2-1 s on a 0.02 m grid): one computation per world
    and process however many episodes it has."""
    line = math.hypot(world.goal[0] - world.start[0], world.goal[1] - world.start[1])
    if line < DEFAULT_RESOLUTION:  # within one cell: no route to search
        return DEFAULT_RESOLUTION
    try:
        return max(shortest_path(world).length, DEFAULT_RESOLUTION)
    except WorldFormatError:
        return line


def official_length(world: World) -> float:
    """L of BARN's official form of the score, m: the world's published reference path length
    (``World.reference_length``, BARN's path files, as BARN's own scorer takes it) where it has
    one, else :func:`reference_length`."""
    if world.reference_length is not None:
        return float(world.reference_length)
    return reference_length(world)
