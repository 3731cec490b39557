"""Where along a world's route does a method get through? Start it part-way and see.

For each fraction of the world's route (``d3dwa_bullet.world.route_start``: the shortest route
keeping 0.30 m from obstacles), runs one noise-free episode of each method starting at
that point, facing along the route, towards the world's own goal. A method that reaches
the goal from 0.4 but not from 0.3 is stuck in the stretch between those points.

    python -m tools.experiments.probe_route TS4  # shipped d3dwa
    python -m tools.experiments.probe_route TS4 --methods d3dwa,dwa3 --fractions 0,0.25,0.5
    python -m tools.experiments.probe_route TS4 --policy runs/x/policy --json

Prints a table (or JSON with ``--json``); exit status 2 on bad input.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from d3dwa_bullet.backends import run_local
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.evaluation.jobs import Job, run_job
from d3dwa_bullet.method_specs import check_method, needs_policy
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import load_world
from d3dwa_bullet.world.route_start import route_polyline, route_pose
from tools.entry import ToolParser, fail, tool_main

DEFAULT_FRACTIONS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)


def start_world(world: World, route: np.ndarray, fraction: float) -> World:
    """The world with its start moved to ``fraction`` of its route (``route_polyline``)."""
    if fraction == 0.0:
        return world
    return world.with_task(start=route_pose(route, fraction))


def _run(job: Job, _: Any) -> tuple[Job, dict[str, Any]]:
    result = run_job(job)
    final = [round(float(result.log[k][-1]), 2) for k in ("x", "y")] if result.steps else None
    return job, result.summary() | {"final_xy": final}


def probe(
    world: World, methods: Sequence[str], fractions: Sequence[float], policy: str | None = None,
    seed: int = 0, workers: int = 1,
) -> list[dict[str, Any]]:  # fmt: skip
    """One row per fraction: the start pose and each method's outcome from there (policy:
    the learned methods'; a fixed or reference method needs none)."""
    route = route_polyline(world)
    starts = {f: start_world(world, route, f) for f in fractions}
    policies = {m: None if not needs_policy(m) else policy for m in methods}
    jobs = [Job(starts[f], m, seed, policy=policies[m]) for f in fractions for m in methods]
    done: dict[Job, dict[str, Any]] = dict(run_local(_run, jobs, None, workers))
    rows = []
    for f in fractions:
        row: dict[str, Any] = {"fraction": f, "start": [round(v, 3) for v in starts[f].start]}
        for m in methods:
            row[m] = done[Job(starts[f], m, seed, policy=policies[m])]
        rows.append(row)
    return rows


def _cell(summary: dict[str, Any]) -> str:
    if summary["outcome"] == "goal":
        return f"goal {summary['time_s']:.1f} s"
    x, y = summary["final_xy"]
    return f"{summary['outcome'][0].upper()} at ({x:.2f}, {y:.2f})"


def format_table(world: World, methods: Sequence[str], rows: Sequence[dict[str, Any]]) -> str:
    head = f"{'fraction':>8} {'start (x, y, yaw)':>22}" + "".join(f" {m:>22}" for m in methods)
    lines = [f"{world.name}: goal {list(world.goal)}", head, "-" * len(head)]
    for r in rows:
        x, y, yaw = r["start"]
        lines.append(
            f"{r['fraction']:>8.2f} {f'({x:.2f}, {y:.2f}, {yaw:.2f})':>22}"
            + "".join(f" {_cell(r[m]):>22}" for m in methods)
        )
    lines.append("T = timeout, C = collision, at the final (x, y); one noise-free episode each")
    return "\n".join(lines)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("world", help="world name or file")
    ap.add_argument("--methods", default="d3dwa", help="comma-separated methods (default d3dwa)")
    ap.add_argument("--policy", default=None, help="policy directory for the learned methods")
    ap.add_argument("--fractions", default=",".join(f"{f:g}" for f in DEFAULT_FRACTIONS),
                    help="comma-separated route fractions in [0, 1)")  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1, help="local processes")
    ap.add_argument("--json", action="store_true", help="print a JSON list of rows")
    args = ap.parse_args(argv)
    try:
        world = load_world(args.world)
        methods = [check_method(m.strip()) for m in args.methods.split(",") if m.strip()]
        if not methods:
            raise D3DWAError("--methods: give at least one method")
        try:
            fractions = [float(f) for f in args.fractions.split(",")]
        except ValueError as err:
            raise D3DWAError(f"--fractions: not a list of numbers ({err})") from err
        route = route_polyline(world)  # WorldFormatError if no route keeps the clearance
        for f in fractions:
            route_pose(route, f)  # ConfigError for a fraction outside [0, 1)
        for m in methods:
            # a bad policy path fails here, not in a worker
            make_controller(m, None if not needs_policy(m) else args.policy)
    except D3DWAError as err:
        fail("probe_route", str(err))
    rows = probe(world, methods, fractions, args.policy, args.seed, args.workers)
    print(json.dumps(rows, indent=2) if args.json else format_table(world, methods, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
