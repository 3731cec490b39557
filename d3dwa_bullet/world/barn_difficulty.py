"""How hard a BARN world is, from its grid and reference path alone (before any method runs).

Measures (after BARN's paper, Perille et al. 2020, "Benchmarking Metric Ground Navigation";
defined here in our own terms on the 30x30 grid, a cell 0.15 m):

- ``clearance_mean`` / ``clearance_min`` (m): distance from each reference path cell's
  centre to the nearest cylinder surface (nearest filled cell centre minus 0.075 m), the
  mean and the minimum over the path's cells. Cells outside the grid count as free.
- ``characteristic_dimension`` (m): at each path cell, the narrowest width through it: for
  :data:`DIRECTIONS` directions over half a turn, the distance between the centres of the
  first filled cells the line through the cell meets in its two senses (a sense that meets
  none counts :data:`RAY_CELLS` cells), less one cylinder diameter; the smallest over
  directions, then the mean over the path's cells.
- ``tortuosity`` (1): the reference polyline's length (start -> cells -> goal,
  :func:`~d3dwa_bullet.world.barn.path_length`) over the straight start-goal distance, 10 m.

The tercile of a world is fixed by one measure, :data:`TERCILE_MEASURE`, chosen before any
method ran: the 300 worlds ranked by mean clearance (most first, ties by world number),
the first 100 ``easy``, the next 100 ``middle``, the last 100 ``hard``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cache

import numpy as np
from scipy import ndimage

from d3dwa_bullet.world.barn import (
    BARN_WORLDS,
    CELL_MM,
    GOAL,
    RADIUS,
    START,
    check_index,
    path_length,
    read_world_file,
    world_file,
)

DIRECTIONS = 16
"""Directions over half a turn for the characteristic dimension."""
RAY_CELLS = 30.0
"""Longest ray of the characteristic dimension, cells (the grid's size)."""
RAY_STEP = 0.25
"""Ray sampling step, cells."""
TERCILE_MEASURE = "clearance_mean"
"""The measure the terciles rank by (more clearance = easier)."""
TERCILES = ("easy", "middle", "hard")
"""Tercile names, easiest first."""
TERCILE_GROUPS = tuple(f"barn-{t}" for t in TERCILES)
"""The layout groups of :func:`barn_tercile_group`, easiest first (the tables' order)."""
CELL = CELL_MM / 1000.0


@dataclass(frozen=True)
class BarnDifficulty:
    """Difficulty measures of one BARN world (see the module docstring)."""

    clearance_mean: float
    """Mean distance from the path cells to the nearest cylinder surface, m."""
    clearance_min: float
    """Smallest such distance, m."""
    characteristic_dimension: float
    """Mean over path cells of the narrowest width through the cell, m."""
    tortuosity: float
    """Reference path length over the straight start-goal distance, 1."""

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


def path_clearance(grid: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance from each path cell's centre to the nearest cylinder surface: (K,) m.

    grid: (30, 30) bool, True = filled; path: (K, 2) int cells (row, column).
    """
    cells = ndimage.distance_transform_edt(~np.asarray(grid, dtype=bool))
    return np.asarray(cells)[path[:, 0], path[:, 1]] * CELL - RADIUS


@cache
def _ray_cells() -> np.ndarray:
    """Cell offsets (2, D, S, 2) int of the rays' samples: both senses of :data:`DIRECTIONS`
    directions, each sample (every :data:`RAY_STEP` cells out to :data:`RAY_CELLS`) rounded
    to its nearest cell."""
    angles = np.arange(DIRECTIONS) * math.pi / DIRECTIONS
    unit = np.stack((np.cos(angles), np.sin(angles)), axis=1)  # (D, 2)
    steps = np.arange(1, int(RAY_CELLS / RAY_STEP) + 1) * RAY_STEP  # (S,)
    ray = unit[:, None, :] * steps[None, :, None]  # (D, S, 2)
    return np.rint(np.stack((ray, -ray))).astype(int)


def narrowest_width(grid: np.ndarray, path: np.ndarray) -> np.ndarray:
    """The narrowest free width through each path cell over :data:`DIRECTIONS` directions:
    (K,) m, the distance between the first filled cells' centres the two senses of a line
    meet (a sense that meets none counts :data:`RAY_CELLS`), less one cylinder diameter."""
    offsets = _ray_cells()
    reach = np.hypot(offsets[..., 0], offsets[..., 1])  # (2, D, S) cells
    pad = int(RAY_CELLS) + 1  # cells beyond the grid are free
    padded = np.pad(np.asarray(grid, dtype=bool), pad, constant_values=False)
    idx = path[:, None, None, None, :] + pad + offsets[None]  # (K, 2, D, S, 2)
    hit = padded[idx[..., 0], idx[..., 1]]  # (K, 2, D, S)
    first = hit.argmax(axis=-1)  # (K, 2, D)
    sense, direction = np.indices(first.shape[1:])
    found = np.where(hit.any(axis=-1), reach[sense, direction, first], RAY_CELLS)
    width = found.sum(axis=1) * CELL - 2 * RADIUS  # (K, D)
    return np.asarray(width.min(axis=1))


def difficulty_of(grid: np.ndarray, path: np.ndarray) -> BarnDifficulty:
    """The measures of a grid (30, 30) bool and its path (K, 2) int cells."""
    clearance = path_clearance(grid, path)
    straight = math.hypot(GOAL[0] - START[0], GOAL[1] - START[1])
    return BarnDifficulty(
        clearance_mean=float(clearance.mean()),
        clearance_min=float(clearance.min()),
        characteristic_dimension=float(narrowest_width(grid, path).mean()),
        tortuosity=path_length(path) / straight,
    )


@cache
def barn_difficulty(index: int) -> BarnDifficulty:
    """The difficulty measures of BARN world ``index`` (cached: the data never changes)."""
    return difficulty_of(*read_world_file(world_file(check_index(index))))


@cache
def _terciles() -> tuple[str, ...]:
    """The tercile of every world, by world number."""
    key = [getattr(barn_difficulty(i), TERCILE_MEASURE) for i in range(BARN_WORLDS)]
    order = sorted(range(BARN_WORLDS), key=lambda i: (-key[i], i))
    size = BARN_WORLDS // len(TERCILES)
    out = [""] * BARN_WORLDS
    for rank, i in enumerate(order):
        out[i] = TERCILES[min(rank // size, len(TERCILES) - 1)]
    return tuple(out)


def barn_tercile(index: int) -> str:
    """``easy``, ``middle`` or ``hard``: the world's tercile by :data:`TERCILE_MEASURE`."""
    return _terciles()[check_index(index)]


def barn_tercile_group(index: int) -> str:
    """The layout group tables show a BARN world's rows under: ``barn-<tercile>``."""
    return f"barn-{barn_tercile(index)}"
