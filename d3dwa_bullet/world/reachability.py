"""Can the planner's full footprint drive from a world's start to its goal?

The inflated point robot of :mod:`~d3dwa_bullet.world.routes` lets through turns into
narrow passages that the planner's collision model (three circles along the body, forward
driving and turning in place) cannot make; :func:`footprint_reachable` searches that model
on an (x, y, heading) lattice over a :func:`~d3dwa_bullet.world.grid.clearance_field`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from d3dwa_bullet.params import Footprint, TerminationParams
from d3dwa_bullet.world.grid import DEFAULT_INFLATION, DEFAULT_MARGIN, Grid, clearance_field
from d3dwa_bullet.world.model import World

FOOTPRINT_RESOLUTION = 0.04
"""Cell size of the (x, y, heading) lattice of :func:`footprint_reachable`, m."""

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
    the inflated point-robot check of :func:`~d3dwa_bullet.world.routes.shortest_path`
    lets through.
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
