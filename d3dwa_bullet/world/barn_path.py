"""BARN's reference path on a grid: the search BARN's generator ran (docs/design/barn-style.md).

Facts from BARN's generator (dperille/jackal-map-creation, read for facts only; this is our
own code). The robot's configuration space on the 30x30 grid blocks every cell with a
filled cell within 2 cells in rows and columns (a 5x5-cell robot). A world is kept when the
largest 4-connected free C-space region touching column 0 is the one touching column 29.
The path runs from a row of column 0 to a row of column 29 of that region by a best-first
search over cells:

- moves to the 8 neighbours, at most a 45 degree turn from the move into the cell (any move
  from the start), never into a blocked cell nor between two blocked orthogonal neighbours;
- cost g: the moves' lengths (1 or sqrt 2 cells); a cell within 2 cells (Euclidean, to the
  nearest blocked C-space cell) of the blocked space adds 5 / that distance to its key;
- the key of a cell first reached is g + penalty; when a cheaper g reaches a cell still
  open, its key becomes g + h + penalty, h the straight distance to the end cell. The open
  cell with the smallest key is expanded next, the first opened on a tie; a cell once
  expanded is never reopened; the search ends when the end cell is expanded.
- The path lists the start cell twice, then every cell to the end (as BARN's path files do).

On BARN's own 300 grids, with each path file's first and last cells, this search gives back
the path file cell for cell (tests/world/test_barn_path.py).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

ROBOT_CELLS = 2
"""Cells the robot takes beyond its centre cell each way: a 5x5-cell robot."""
INFLATION_CELLS = 2
"""Cells near the blocked space that cost extra: BARN's 0.3 m inflation over 0.15 m cells."""
PENALTY = 5.0
"""Extra key of a cell at distance d <= INFLATION_CELLS from the blocked space: PENALTY / d."""
_FIRST_MOVES = ((0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1))
"""The moves from the start cell, in the order they are tried."""


def c_space(grid: np.ndarray) -> np.ndarray:
    """(30, 30) bool, True = blocked for the robot's centre: a filled cell of ``grid`` (30, 30)
    bool within ROBOT_CELLS rows and columns (cells outside the grid count as free)."""
    size = 2 * ROBOT_CELLS + 1
    grid = np.asarray(grid, dtype=bool)
    return np.asarray(ndimage.maximum_filter(grid, size=size, mode="constant", cval=False))


def crossing_region(blocked: np.ndarray) -> np.ndarray | None:
    """(30, 30) bool: the free C-space region the robot crosses in, or None if it cannot.

    blocked: (30, 30) bool C-space. The largest 4-connected free region touching column 0
    (the first such row's on a tie) must be the largest touching the last column."""
    labels, _ = ndimage.label(~np.asarray(blocked, dtype=bool))
    sizes = np.bincount(labels.ravel())

    def biggest(column: np.ndarray) -> int:
        best, best_size = 0, 0
        for label in column:
            if label and sizes[label] > best_size:
                best, best_size = int(label), int(sizes[label])
        return best

    left, right = biggest(labels[:, 0]), biggest(labels[:, -1])
    if left == 0 or left != right:
        return None
    return labels == left


def wall_distance(blocked: np.ndarray) -> np.ndarray:
    """(30, 30) float, cells: Euclidean distance from each cell to the nearest blocked cell."""
    return np.asarray(ndimage.distance_transform_edt(~np.asarray(blocked, dtype=bool)))


def _turns(move: tuple[int, int]) -> tuple[tuple[int, int], ...]:
    """The moves at most 45 degrees from ``move``: left of it, itself, right of it."""
    i = _FIRST_MOVES.index(move)
    return tuple(_FIRST_MOVES[(i + k) % 8] for k in (-1, 0, 1))


_NEXT = {m: _turns(m) for m in _FIRST_MOVES}


def barn_search(
    blocked: np.ndarray, start: tuple[int, int], end: tuple[int, int]
) -> np.ndarray | None:
    """BARN's path (module docstring) from cell ``start`` to cell ``end`` (row, column):
    (K, 2) int64 cells, the start twice first; None if the search finds none.

    blocked: (R, C) bool C-space. ValueError if start or end is blocked."""
    blocked = np.asarray(blocked, dtype=bool)
    rows, cols = blocked.shape
    for cell in (start, end):
        if blocked[cell]:
            raise ValueError(f"cell {cell} is blocked")
    dist = wall_distance(blocked)
    g: dict[tuple[int, int], float] = {start: 0.0}
    key: dict[tuple[int, int], float] = {start: 0.0}
    parent: dict[tuple[int, int], tuple[int, int] | None] = {start: None}
    open_cells: list[tuple[int, int]] = [start]  # in the order opened
    closed: set[tuple[int, int]] = set()
    while open_cells:
        best = min(range(len(open_cells)), key=lambda i: key[open_cells[i]])  # first on a tie
        cell = open_cells.pop(best)
        closed.add(cell)
        if cell == end:
            path = [cell]
            while (up := parent[path[-1]]) is not None:
                path.append(up)
            path.append(start)
            return np.array(path[::-1], dtype=np.int64)
        up = parent[cell]
        moves = _FIRST_MOVES if up is None else _NEXT[(cell[0] - up[0], cell[1] - up[1])]
        for dr, dc in moves:
            r, c = cell[0] + dr, cell[1] + dc
            if not (0 <= r < rows and 0 <= c < cols) or blocked[r, c]:
                continue
            if dr and dc and blocked[cell[0] + dr, cell[1]] and blocked[cell[0], cell[1] + dc]:
                continue
            child = (r, c)
            if child in closed:
                continue
            child_g = g[cell] + math.sqrt(dr * dr + dc * dc)
            d = float(dist[r, c])
            penalty = PENALTY / d if d <= INFLATION_CELLS else 0.0
            if child in g:  # open
                if child_g < g[child]:
                    parent[child], g[child] = cell, child_g
                    key[child] = child_g + math.hypot(r - end[0], c - end[1]) + penalty
            else:
                parent[child], g[child], key[child] = cell, child_g, child_g + penalty
                open_cells.append(child)
    return None
