"""Time one global-plan search on BARN costmaps with four libraries (docs/design/global-plan.md).

Each BARN world's known map becomes the global plan's costmap (0.05 m cells, lethal within the
planner's r + m, Nav2's inflation cost beyond); the shortest path from start to goal is then found
by scikit-image's MCP_Geometric, SciPy's csgraph Dijkstra (graph built each search), pyastar2d's
A* and networkx's A*, all 8-connected. Prints the median seconds per search, each library's
ratio to the fastest, the largest relative difference of its path's cost (MCP's step cost: the
mean of the two cells' costs times the step length) from MCP's, and the mean path length.
pyastar2d charges a diagonal step like a straight one, so its paths are not the shortest ones.

    python -m tools.bench.bench_global_plan --json
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable, Sequence

import numpy as np

from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.costmap import RESOLUTION, cell_costs, cell_of, shortest_path
from d3dwa_bullet.world.barn import barn_world
from d3dwa_bullet.world.grid import clearance_field
from tools.entry import ToolParser, tool_main

_STEPS = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]


def _path_cost(costs: np.ndarray, cells: np.ndarray) -> float:
    """MCP_Geometric's cost of a path: mean of the two cells' costs times the step length."""
    a, b = cells[:-1], cells[1:]
    step = np.hypot(*(b - a).T)
    return float(np.sum(0.5 * (costs[a[:, 0], a[:, 1]] + costs[b[:, 0], b[:, 1]]) * step))


def by_mcp(costs: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray | None:
    return shortest_path(costs, s, g)


def by_csgraph(costs: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray | None:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    ny, nx = costs.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    rows, cols, weights = [], [], []
    for di, dj in _STEPS:
        a = idx[max(0, -di) : ny - max(0, di), max(0, -dj) : nx - max(0, dj)]
        b = idx[max(0, di) : ny + min(0, di), max(0, dj) : nx + min(0, dj)]
        w = 0.5 * (costs.ravel()[a.ravel()] + costs.ravel()[b.ravel()]) * np.hypot(di, dj)
        ok = np.isfinite(w)
        rows.append(a.ravel()[ok])
        cols.append(b.ravel()[ok])
        weights.append(w[ok])
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(ny * nx,) * 2,
    ).tocsr()
    dist, pred = dijkstra(graph, indices=idx[s], return_predecessors=True)
    if not np.isfinite(dist[idx[g]]):
        return None
    out, k = [], idx[g]
    while k >= 0:
        out.append(divmod(int(k), nx))
        k = pred[k]
    return np.asarray(out[::-1])


def by_pyastar2d(costs: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray | None:
    import pyastar2d

    return pyastar2d.astar_path(costs.astype(np.float32), s, g, allow_diagonal=True)


def by_networkx(costs: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> np.ndarray | None:
    import networkx as nx

    graph = nx.Graph()
    ny, nxx = costs.shape
    for i in range(ny):
        for j in range(nxx):
            if not np.isfinite(costs[i, j]):
                continue
            for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
                a, b = i + di, j + dj
                if 0 <= a < ny and 0 <= b < nxx and np.isfinite(costs[a, b]):
                    graph.add_edge(
                        (i, j), (a, b), weight=0.5 * (costs[i, j] + costs[a, b]) * np.hypot(di, dj)
                    )
    return np.asarray(nx.astar_path(graph, s, g, weight="weight"))


LIBRARIES: dict[str, Callable] = {
    "skimage_mcp": by_mcp,
    "scipy_csgraph": by_csgraph,
    "pyastar2d": by_pyastar2d,
    "networkx": by_networkx,
}


def bench(worlds: Sequence[int], repeats: int) -> dict:
    lethal = PlannerParams().admissible_clearance
    times: dict[str, list[float]] = {k: [] for k in LIBRARIES}
    agree: dict[str, float] = {k: 0.0 for k in LIBRARIES}
    length: dict[str, list[float]] = {k: [] for k in LIBRARIES}
    cells = 0
    for index in worlds:
        world = barn_world(index)
        field = clearance_field(world, RESOLUTION, margin=2.0)
        costs = cell_costs(field.values, lethal)
        cells = costs.size
        s, g = cell_of(field, world.start[:2]), cell_of(field, world.goal)
        assert s is not None and g is not None
        best = None
        for name, search in LIBRARIES.items():
            for _ in range(1 if name == "networkx" else repeats):
                t0 = time.perf_counter()
                path = search(costs, s, g)
                times[name].append(time.perf_counter() - t0)
            cost = _path_cost(costs, path) if path is not None else float("inf")
            if path is not None:
                length[name].append(float(np.hypot(*np.diff(path, axis=0).T).sum()) * RESOLUTION)
            best = cost if best is None else best
            agree[name] = max(agree[name], abs(cost - best) / best)
    med = {k: statistics.median(v) for k, v in times.items()}
    fastest = min(med.values())
    return {
        "worlds": list(worlds),
        "cells": cells,
        "median_s": {k: round(v, 5) for k, v in med.items()},
        "ratio_to_fastest": {k: round(v / fastest, 1) for k, v in med.items()},
        "path_cost_rel_diff_vs_mcp": {k: round(v, 4) for k, v in agree.items()},
        "mean_path_length_m": {k: round(statistics.mean(v), 2) for k, v in length.items() if v},
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    p = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", default="0,50,100,150,200,250", help="BARN world indices")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    out = bench([int(w) for w in args.worlds.split(",")], args.repeats)
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
