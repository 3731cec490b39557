"""Benchmark what a BARN world costs: World.distance over its hundreds of cylinders, measured
at once against obstacle by obstacle, and one episode's wall time on BARN against R-style.

    python -m tools.bench.bench_barn
    python -m tools.bench.bench_barn --world BARN-0 --against R2 --json

Two distance queries: a few points (``--points`` along the start-goal line, as a route's
waypoints or a start check ask), measured against every cylinder at once; and an episode's
body-clearance query (``episode_metrics.body_clearance``: the body outline at ``--poses``
poses), which stays obstacle by obstacle (faster at that size). Episodes run ``dwa3`` at
seed 0, once to warm up (imports, numba), then timed; wall time per control step is printed
beside the total, since the two worlds' episodes last different simulated times.
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from collections.abc import Callable, Sequence

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.geometry import body_outline
from d3dwa_bullet.world.model import World, obstacle_distance
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main


def distance_one_by_one(world: World, points: np.ndarray) -> np.ndarray:
    """World.distance as it was: the minimum over obstacles taken one at a time, (N,) m.
    The reference the vectorised World.distance must equal bit for bit."""
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    best = np.full(len(pts), np.inf)
    for ob in world.obstacles:
        best = np.minimum(best, obstacle_distance(ob, pts))
    return best


def best_of(fn: Callable[[], object], repeats: int) -> float:
    """The fastest of ``repeats`` calls, s."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def clearance_query(world: World, poses: int) -> np.ndarray:
    """The body outline at ``poses`` poses from start to goal: (P, 2) m."""
    line = np.linspace(world.start[:2], world.goal, poses)
    yaw = np.full((poses, 1), world.start[2])
    return body_outline(np.hstack((line, yaw))).reshape(-1, 2)


def episode_wall(world: World) -> dict[str, float]:
    """Wall time of one dwa3 episode at seed 0 after a warm-up run: total s, steps, ms/step."""
    run_episode(world, make_controller("dwa3"))
    t = time.perf_counter()
    result = run_episode(world, make_controller("dwa3")).summary()
    wall = time.perf_counter() - t
    return {"wall_s": wall, "steps": result["steps"], "ms_per_step": 1e3 * wall / result["steps"]}


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--world", default="BARN-0", help="the BARN world (default: %(default)s)")
    ap.add_argument("--against", default="R2", help="the R-style world (default: %(default)s)")
    ap.add_argument("--points", type=int, default=100, help="points in the small query")
    ap.add_argument("--poses", type=int, default=320, help="poses in the body-clearance query")
    ap.add_argument("--repeats", type=int, default=5, help="timings kept at their best")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    barn, other = load_world(args.world), load_world(args.against)
    line = np.linspace(barn.start[:2], barn.goal, args.points)
    queries = {"waypoint": line, "body outline": clearance_query(barn, args.poses)}
    distance = {}
    for label, pts in queries.items():
        if not np.array_equal(barn.distance(pts), distance_one_by_one(barn, pts)):
            raise SystemExit("bench_barn: error: World.distance differs from the reference")
        loop = best_of(functools.partial(distance_one_by_one, barn, pts), args.repeats)
        now = best_of(functools.partial(barn.distance, pts), args.repeats)
        distance[label] = {"points": len(pts), "one_by_one_ms": 1e3 * loop, "ms": 1e3 * now,
                           "speedup": loop / now}  # fmt: skip
    episodes = {w.name: episode_wall(w) for w in (barn, other)}
    if args.json:
        print(json.dumps({"world": barn.name, "obstacles": len(barn.obstacles),
                          "distance": distance, "episode": episodes}, indent=1))  # fmt: skip
        return
    for label, d in distance.items():
        print(
            f"World.distance on {barn.name} ({len(barn.obstacles)} obstacles), {d['points']} "
            f"{label} points: {d['one_by_one_ms']:.2f} ms one by one, {d['ms']:.2f} ms now "
            f"({d['speedup']:.1f}x)"
        )
    for name, e in episodes.items():
        print(f"episode {name} dwa3 seed 0: {e['wall_s']:.2f} s wall, {e['steps']:.0f} steps, "
              f"{e['ms_per_step']:.2f} ms/step")  # fmt: skip
    ratio = episodes[barn.name]["ms_per_step"] / episodes[other.name]["ms_per_step"]
    print(f"wall per step, {barn.name} / {other.name}: {ratio:.2f}")


if __name__ == "__main__":
    raise SystemExit(main())
