"""A global costmap and the shortest path on it (Nav2's planner server, docs/design/global-plan.md).

Pure maths (numpy, SciPy, scikit-image; no simulator). A costmap is a distance field on a grid
(:class:`~d3dwa_bullet.world.grid.Grid`: m from each cell centre to the nearest obstacle)
turned into a cost per cell the way Nav2's inflation layer and NavFn do it:

* lethal (impassable) where the distance is at most the planner's r + m (base_link is planned
  as a point, as :mod:`d3dwa_bullet.world.grid` does);
* beyond it, up to ``INFLATION_RADIUS``, NavFn's ``COST_NEUTRAL + COST_FACTOR * cost`` with
  the inflation layer's ``252 * exp(-COST_SCALING * (d - r - m))``, divided by COST_NEUTRAL
  so a free cell costs 1 per cell crossed;
* unknown cells are free (Nav2's ``track_unknown_space: true`` with NavFn's
  ``allow_unknown: true``, the common configuration): a scan costmap holds only what was seen.

The search is scikit-image's ``MCP_Geometric`` (8-connected, diagonal steps cost sqrt(2)):
the fastest of four libraries on a BARN costmap (``tools/bench/bench_global_plan.py``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from skimage.graph import MCP_Geometric

from d3dwa_bullet.world.grid import Grid

RESOLUTION = 0.05
"""Costmap cell, m (Nav2's usual ``resolution``)."""
INFLATION_RADIUS = 0.55
"""Distance from an obstacle where the inflation cost ends, m (nav2_params.yaml)."""
COST_SCALING = 3.0
"""Exponential decay of the inflation cost, 1/m (nav2_params.yaml's ``cost_scaling_factor``)."""
INSCRIBED_COST = 252
"""Nav2's cost of a cell just outside the lethal zone (INSCRIBED_INFLATED_OBSTACLE - 1)."""
COST_NEUTRAL = 50
"""NavFn's cost of a free cell."""
COST_FACTOR = 0.8
"""NavFn's weight on the costmap's cost."""
PENALTY = COST_FACTOR * INSCRIBED_COST / COST_NEUTRAL
"""Extra cost per cell just outside the lethal zone, in free cells (about 4.0)."""


def cell_costs(distance: np.ndarray, lethal: float) -> np.ndarray:
    """(ny, nx) float64 cost of crossing each cell: inf where distance (ny, nx, m) <= lethal
    (m), 1 + PENALTY * exp(-COST_SCALING * (d - lethal)) up to INFLATION_RADIUS, 1 beyond."""
    d = np.asarray(distance, dtype=np.float64)
    costs = 1.0 + PENALTY * np.exp(-COST_SCALING * np.maximum(d - lethal, 0.0))
    costs[d > INFLATION_RADIUS] = 1.0
    costs[d <= lethal] = np.inf
    return costs


def occupancy_distance(occupied: np.ndarray, resolution: float) -> np.ndarray:
    """(ny, nx) m from each cell centre to the nearest occupied cell's centre (0 on one; a
    large value everywhere when nothing is occupied)."""
    if not occupied.any():
        return np.full(occupied.shape, 1e9)
    return ndimage.distance_transform_edt(~occupied) * resolution


def cell_of(grid: Grid, xy: tuple[float, float] | np.ndarray) -> tuple[int, int] | None:
    """(row, col) of the cell holding point xy (m), or None outside the grid."""
    j = int(math.floor((xy[0] - grid.origin[0]) / grid.resolution + 0.5))
    i = int(math.floor((xy[1] - grid.origin[1]) / grid.resolution + 0.5))
    ny, nx = grid.shape
    return (i, j) if 0 <= i < ny and 0 <= j < nx else None


def cells_to_points(grid: Grid, cells: np.ndarray) -> np.ndarray:
    """(K, 2) cell centres (x, y), m, of (K, 2) (row, col) cells."""
    cells = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return np.column_stack(
        (
            grid.origin[0] + cells[:, 1] * grid.resolution,
            grid.origin[1] + cells[:, 0] * grid.resolution,
        )
    )


def free_start(costs: np.ndarray, start: tuple[int, int], radius_cells: int) -> np.ndarray:
    """costs with the lethal cells within radius_cells of start made passable at the
    inscribed cost: a robot pinned closer than r + m to an obstacle (where a stall often ends)
    still gets a path out (Nav2 clears the robot's own footprint in the same way)."""
    i, j = start
    ny, nx = costs.shape
    i0, i1 = max(0, i - radius_cells), min(ny, i + radius_cells + 1)
    j0, j1 = max(0, j - radius_cells), min(nx, j + radius_cells + 1)
    ii, jj = np.mgrid[i0:i1, j0:j1]
    near = (ii - i) ** 2 + (jj - j) ** 2 <= radius_cells**2
    window = costs[i0:i1, j0:j1]
    if not np.isinf(window[near]).any():
        return costs
    out = costs.copy()
    sub = out[i0:i1, j0:j1]
    sub[near & np.isinf(sub)] = 1.0 + PENALTY
    return out


def shortest_path(
    costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int]
) -> np.ndarray | None:
    """(K, 2) int (row, col) cells from start to goal (both included) of least summed cost on
    an 8-connected grid (costs (ny, nx), inf impassable), or None when no path exists."""
    if not (np.isfinite(costs[start]) and np.isfinite(costs[goal])):
        return None
    mcp = MCP_Geometric(costs, fully_connected=True)
    cumulative, _ = mcp.find_costs([start], [goal], find_all_ends=True)
    if not np.isfinite(cumulative[goal]):
        return None
    return np.asarray(mcp.traceback(goal), dtype=np.int64).reshape(-1, 2)
