"""Worlds on a grid: clearance fields, occupancy, shortest paths and footprint reachability.

Pure functions over a :class:`~d3dwa_bullet.world.World`, no simulator. Used to check that
a world is passable and how long its shortest route is (``scripts/check_worlds.py``), to
reject impassable generated layouts, and by plots and tests.

Grid convention: ``values[i, j]`` is the cell whose centre is at
``(origin[0] + j * resolution, origin[1] + i * resolution)``: row index grows with y (unlike
an image). The origin is a multiple of the resolution, so whole-metre points such as the
start (0, 0) fall on cell centres.

Passability is judged for a circle about base_link that must keep its centre farther than
the planner's r + m (0.20 m) from every obstacle: obstacles are inflated by r + m and the
robot becomes a point. :func:`footprint_reachable` additionally checks the planner's full
collision model (three circles along the body, forward driving and turning in place).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order, dijkstra

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.params import Footprint, PlannerParams, TerminationParams
from d3dwa_bullet.world.model import Box, Cylinder, World, obstacle_distance

DEFAULT_RESOLUTION = 0.02
"""Cell size of the path-length grid, m."""
DEFAULT_INFLATION = PlannerParams().admissible_clearance
"""Obstacle inflation for a point robot at base_link: the planner's r + m, m."""
DEFAULT_MARGIN = 1.0
"""Free border around the world's bounds, so open worlds can be bypassed on the outside, m."""
FIELD_CAP = 1.0
"""Clearance values are exact up to this distance and capped there, m (> inflation + ROUTE_TUBE)."""
ROUTE_TUBE = 0.5
"""Half-width of the tube around the shortest path in which its bottleneck is measured, m."""
ENDPOINT_RADIUS = 0.25
"""Around start and goal the bottleneck is not measured (their own clearance is no passage), m."""
FOOTPRINT_RESOLUTION = 0.04
"""Cell size of the (x, y, heading) lattice of :func:`footprint_reachable`, m."""
OUTLINE_SAMPLES = 256
"""Points per obstacle outline when looking for passages between obstacles."""

#: The SPEC section 8 "path length" column (TL of the best method), m: design targets.
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

# The 16 lattice steps (dx, dy) of a 16-connected grid, ordered counter-clockwise from +x.
_LATTICE_STEPS = sorted(
    [
        (dx, dy)
        for dx in range(-2, 3)
        for dy in range(-2, 3)
        if (dx, dy) != (0, 0) and math.gcd(abs(dx), abs(dy)) == 1
    ],
    key=lambda s: math.atan2(s[1], s[0]) % (2 * math.pi),
)


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


def _extent(ob: Box | Cylinder) -> tuple[float, float]:
    """Half extents (x, y) of an obstacle's axis-aligned bounding box, m."""
    if isinstance(ob, Cylinder):
        return ob.radius, ob.radius
    c, s = abs(math.cos(ob.yaw)), abs(math.sin(ob.yaw))
    return (
        0.5 * (ob.size[0] * c + ob.size[1] * s),
        0.5 * (ob.size[0] * s + ob.size[1] * c),
    )


def outline(ob: Box | Cylinder, samples: int = OUTLINE_SAMPLES) -> np.ndarray:
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


def _corners(box: Box) -> np.ndarray:
    """The four corners of a box, (4, 2) float64, m, counter-clockwise."""
    hx, hy = 0.5 * box.size[0], 0.5 * box.size[1]
    local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
    c, s = math.cos(box.yaw), math.sin(box.yaw)
    return np.asarray(box.center) + local @ np.array([[c, s], [-s, c]])


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


def gap_between(a: Box | Cylinder, b: Box | Cylinder) -> float:
    """Free distance between two obstacle footprints, m (<= 0 if they touch or overlap).

    Exact: between two disjoint convex polygons the closest pair always includes a
    corner of one of them, and a cylinder is its centre grown by the radius.
    """
    if isinstance(a, Cylinder) and isinstance(b, Cylinder):
        return math.dist(a.center, b.center) - a.radius - b.radius
    if isinstance(a, Cylinder) or isinstance(b, Cylinder):
        cyl, box = (a, b) if isinstance(a, Cylinder) else (b, a)
        return float(obstacle_distance(box, np.array([cyl.center]))[0]) - cyl.radius
    ca, cb = _corners(a), _corners(b)  # type: ignore[arg-type]
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
    rims = [outline(ob, samples) for ob in obs]
    reach = [float(np.hypot(*_extent(ob))) for ob in obs]
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
        ex, ey = _extent(ob)
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


def _shifted(
    padded: np.ndarray, pad: int, shape: tuple[int, int], res: float, dx: float, dy: float
) -> np.ndarray:
    """A field sampled at every cell centre + (dx, dy) m, bilinear: (ny, nx).

    ``padded`` is the field edge-padded by ``pad`` cells, ``pad`` > |shift| / res.
    """
    ny, nx = shape
    fj, fi = dx / res, dy / res
    j0, i0 = math.floor(fj), math.floor(fi)
    tj, ti = fj - j0, fi - i0
    r0, c0 = pad + i0, pad + j0
    v00 = padded[r0 : r0 + ny, c0 : c0 + nx]
    v01 = padded[r0 : r0 + ny, c0 + 1 : c0 + 1 + nx]
    v10 = padded[r0 + 1 : r0 + 1 + ny, c0 : c0 + nx]
    v11 = padded[r0 + 1 : r0 + 1 + ny, c0 + 1 : c0 + 1 + nx]
    return (1 - ti) * ((1 - tj) * v00 + tj * v01) + ti * ((1 - tj) * v10 + tj * v11)


def _reachable_window(world: World, field: Grid, clearance: float) -> Grid | None:
    """Crop a field to the part a point with this clearance can reach from the start.

    A necessary condition for any robot pose, so nothing the footprint could use is lost;
    None if the start itself has less clearance.
    """
    labels, _ = ndimage.label(field.values > clearance, structure=np.ones((3, 3)))
    (si, sj), (gi, gj) = field.cell_of(np.array([world.start[:2], world.goal]))
    if labels[si, sj] == 0 or labels[si, sj] != labels[gi, gj]:
        return None
    rows, cols = np.nonzero(labels == labels[si, sj])
    pad = 2
    ny, nx = field.shape
    i0, j0 = max(0, rows.min() - pad), max(0, cols.min() - pad)
    i1, j1 = min(ny, rows.max() + pad + 1), min(nx, cols.max() + pad + 1)
    return Grid(
        values=field.values[i0:i1, j0:j1],
        origin=(field.origin[0] + j0 * field.resolution, field.origin[1] + i0 * field.resolution),
        resolution=field.resolution,
    )


def footprint_reachable(
    world: World,
    footprint: Footprint | None = None,
    clearance: float = DEFAULT_INFLATION,
    resolution: float = FOOTPRINT_RESOLUTION,
    goal_tolerance: float = TerminationParams().goal_tolerance,
    margin: float = DEFAULT_MARGIN,
) -> bool:
    """Can the planner's full footprint drive from the start pose to the goal?

    The robot is the planner's circles along the body axis (``footprint.centers_x``); a
    pose is admissible when every circle centre is > ``clearance`` from all obstacles.
    Motions: drive forward along the heading (16 lattice headings, 16-connected steps,
    no reversing, as the planner samples v >= 0) and turn in place to the next heading
    (the half-way heading is checked too). This catches turns into narrow passages that
    the inflated point-robot check of :func:`shortest_path` lets through.
    """
    fp = footprint or Footprint()
    field = _reachable_window(
        world,
        clearance_field(world, resolution, margin),
        clearance - max(abs(c) for c in fp.centers_x),
    )
    if field is None:
        return False
    ny, nx = field.shape
    steps = np.array(_LATTICE_STEPS)
    headings = np.arctan2(steps[:, 1], steps[:, 0]) % (2 * np.pi)
    k = len(headings)
    mids = headings + 0.5 * np.diff(np.append(headings, headings[0] + 2 * np.pi))
    pad = math.ceil(max(abs(c) for c in fp.centers_x) / resolution) + 2
    padded = np.pad(field.values, pad, mode="edge")

    def admissible(theta: float) -> np.ndarray:
        ok = np.ones((ny, nx), dtype=bool)
        for cx in fp.centers_x:
            shift = (cx * math.cos(theta), cx * math.sin(theta))
            ok &= _shifted(padded, pad, (ny, nx), resolution, *shift) > clearance
        return ok

    free = np.stack([admissible(float(t)) for t in headings])
    turn_ok = np.stack([admissible(float(t)) for t in mids])
    idx = np.arange(k * ny * nx).reshape(k, ny, nx)
    src, dst = [], []
    # A step is at most 2 cells (0.09 m): far narrower than any inadmissible band
    # (>= 2 x clearance wide), so checking its two end poses cannot jump an obstacle.
    for h, (dx, dy) in enumerate(_LATTICE_STEPS):
        a = (slice(max(0, -dy), ny - max(0, dy)), slice(max(0, -dx), nx - max(0, dx)))
        b = (slice(max(0, dy), ny - max(0, -dy)), slice(max(0, dx), nx - max(0, -dx)))
        move = free[h][a] & free[h][b]
        src.append(idx[h][a][move])
        dst.append(idx[h][b][move])
        h2 = (h + 1) % k
        turn = free[h] & free[h2] & turn_ok[h]
        for p, q in ((h, h2), (h2, h)):
            src.append(idx[p][turn])
            dst.append(idx[q][turn])
    s, d = np.concatenate(src), np.concatenate(dst)
    graph = csr_matrix((np.ones(s.size), (s, d)), shape=(k * ny * nx, k * ny * nx))
    (si, sj), (gi, gj) = field.cell_of(np.array([world.start[:2], world.goal]))
    h0 = int(np.argmin(np.abs(np.angle(np.exp(1j * (headings - world.start[2]))))))
    if not free[h0, si, sj]:
        return False
    reached = breadth_first_order(
        graph, int(idx[h0, si, sj]), directed=True, return_predecessors=False
    )
    _, ii, jj = np.unravel_index(reached, (k, ny, nx))
    pts = field.point_of(np.column_stack((ii, jj)))
    return bool((np.hypot(*(pts - np.asarray(world.goal)).T) <= goal_tolerance).any())


def geodesic_field(
    world: World,
    resolution: float = DEFAULT_RESOLUTION,
    inflation: float = DEFAULT_INFLATION,
    margin: float = DEFAULT_MARGIN,
) -> Grid:
    """Length of the shortest route from every cell to the goal, m (inf where the cell is
    blocked or cut off), with obstacles inflated by ``inflation``: 8-connected Dijkstra from
    the goal cell, which counts as free. Privileged map knowledge: for diagnostics such as
    :mod:`d3dwa_bullet.oracle`, never for the observation."""
    field = clearance_field(world, resolution, margin)
    free = field.values > inflation
    gi, gj = field.cell_of(np.array([world.goal], dtype=np.float64))[0]
    free[gi, gj] = True
    dist = dijkstra(_grid_graph(free, resolution), directed=True, indices=gi * free.shape[1] + gj)
    dist = dist.reshape(free.shape)
    dist[~free] = np.inf
    return Grid(values=dist, origin=field.origin, resolution=resolution)
