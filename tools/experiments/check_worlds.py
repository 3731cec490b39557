"""Check worlds: passability, shortest-route length and the narrowest gap on that route.

For each shipped world (or the world files given), rasterise it at 0.02 m, inflate the
obstacles by the planner's r + m = 0.20 m, and find the shortest route for base_link from
start to goal (8-connected Dijkstra, then line-of-sight smoothing). Prints a table, or a
JSON list with ``--json``. With ``--footprint`` it also checks that the planner's
three-circle footprint can drive the route forward-only with turns in place (slower).

    python -m tools.experiments.check_worlds  # all shipped worlds
    python -m tools.experiments.check_worlds --footprint
    python -m tools.experiments.check_worlds my.world --goal 3 0 --json

Exit status 1 if any world has no route.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from typing import Any

from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.world.grid import DEFAULT_INFLATION, DEFAULT_RESOLUTION
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.reachability import footprint_reachable
from d3dwa_bullet.world.registry import list_worlds, load_world_file
from d3dwa_bullet.world.routes import REFERENCE_PATH_LENGTHS, shortest_path
from tools.entry import ToolParser, fail, tool_main


def check_world(
    world: World,
    resolution: float = DEFAULT_RESOLUTION,
    inflation: float = DEFAULT_INFLATION,
    footprint: bool = False,
) -> dict[str, Any]:
    """One row of the report: lengths in m; ``error`` is set when there is no route."""
    straight = math.dist(world.start[:2], world.goal)
    row: dict[str, Any] = {
        "name": world.name,
        "group": world.group,
        "obstacles": len(world.obstacles),
        "straight": round(straight, 3),
        "target": REFERENCE_PATH_LENGTHS.get(world.name) if world.group != "custom" else None,
    }
    try:
        path = shortest_path(world, resolution=resolution, inflation=inflation)
    except D3DWAError as err:
        return row | {"path": None, "error": str(err)}
    row |= {
        "path": round(path.length, 3),
        "grid_path": round(path.grid_length, 3),
        "min_clearance": round(path.min_clearance, 3),
        "bottleneck": round(path.bottleneck, 3),
        "error": None,
    }
    if row["target"]:
        row["deviation"] = round(path.length / row["target"] - 1.0, 3)
    if footprint:
        row["footprint_ok"] = footprint_reachable(world, clearance=inflation)
    return row


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """Fixed-width text table of check_world rows."""
    with_fp = any("footprint_ok" in r for r in rows)
    head = f"{'world':<14} {'group':<7} {'obst':>4} {'straight':>8} {'path':>7} {'target':>6} {'dev':>6} {'narrowest':>9} {'gap':>5}"
    head += "  footprint" if with_fp else ""
    lines = [head, "-" * len(head)]
    for r in rows:
        line = f"{r['name']:<14} {r['group']:<7} {r['obstacles']:>4} {r['straight']:>8.2f} "
        if r["path"] is None:
            lines.append(line + f"NO ROUTE: {r['error']}")
            continue
        target = f"{r['target']:>6.2f}" if r["target"] else f"{'-':>6}"
        dev = f"{100 * r['deviation']:>+5.0f}%" if r["target"] else f"{'-':>6}"
        line += (
            f"{r['path']:>7.2f} {target} {dev} {r['bottleneck']:>9.2f} {2 * r['bottleneck']:>5.2f}"
        )
        if with_fp:
            line += f"  {'ok' if r.get('footprint_ok') else 'BLOCKED'}"
        lines.append(line)
    lines.append(
        "path: shortest route of base_link with obstacles inflated by "
        f"{DEFAULT_INFLATION:.2f} m; narrowest: the clearance the route can keep through its "
        "tightest spot (half the gap width, capped in open space); gap = 2 x narrowest"
    )
    return "\n".join(lines)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="*", help="world files (default: every shipped world)")
    ap.add_argument("--json", action="store_true", help="print a JSON list of dicts")
    ap.add_argument("--resolution", type=float, default=DEFAULT_RESOLUTION, help="grid cell, m")
    ap.add_argument(
        "--inflation", type=float, default=DEFAULT_INFLATION, help="obstacle inflation, m"
    )
    ap.add_argument("--footprint", action="store_true", help="also check the 3-circle footprint")
    ap.add_argument(
        "--start", type=float, nargs=3, metavar=("X", "Y", "YAW"), help="override start"
    )
    ap.add_argument("--goal", type=float, nargs=2, metavar=("X", "Y"), help="override goal")
    args = ap.parse_args(argv)
    try:
        worlds = [load_world_file(p) for p in args.paths] if args.paths else list_worlds()
        if args.start or args.goal:
            worlds = [w.with_task(start=args.start, goal=args.goal) for w in worlds]
    except D3DWAError as err:
        fail("check_worlds", str(err))
    rows = [check_world(w, args.resolution, args.inflation, args.footprint) for w in worlds]
    print(json.dumps(rows, indent=2) if args.json else format_table(rows))
    return 1 if any(r["path"] is None for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
