"""Benchmark the kinematic backend against PyBullet, in one run: whole episodes, the lidar, a step.

    python -m tools.bench.bench_backend
    python -m tools.bench.bench_backend --worlds BARN-0,BARN-150,R1,R2 --methods dwa3,d3dwa --json

Episodes: each method on each world at seed 0 without noise, on both backends, once to warm up
(imports, numba's compiled kernels), then ``--repeats`` times each, the two backends taking
turns so a change of the machine's load falls on both; the figure is the process's CPU time
(``time.process_time``, which counts Bullet's ray threads too). The ratio is the CPU of all
PyBullet episodes over all kinematic ones, and per control step (the two may end an episode at
different steps). Parts: the lidar's true ranges at the start pose (``rayTestBatch`` against
the numba ray cast) and one control step's motion (24 Bullet sub-steps against the kinematic
wheel model), each the best of ``--parts-repeats`` timings.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Sequence
from typing import Any

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, run_episode
from d3dwa_bullet.sim.kinematic import KinematicSimulator
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main

BACKENDS = ("pybullet", "kinematic")


def episode_cpu(world, method: str, backend: str) -> tuple[float, int, str]:
    """(CPU s, steps, outcome) of one episode of method on world at seed 0."""
    controller = make_controller(method)
    t = time.process_time()
    result = run_episode(world, controller, seed=0, config=EpisodeConfig(backend=backend))
    return time.process_time() - t, result.steps, result.outcome


def best_cpu(fn: Callable[[], object], repeats: int) -> float:
    """The least CPU time of ``repeats`` calls, s."""
    best = float("inf")
    for _ in range(repeats):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best


def parts(world, repeats: int) -> dict[str, float]:
    """Lidar and one step's motion on both backends, us, at the world's start."""
    kin = KinematicSimulator(world)
    with Simulator(world) as bullet:
        out = {
            "lidar_pybullet_us": 1e6 * best_cpu(bullet.lidar.ranges, repeats),
            "step_pybullet_us": 1e6 * best_cpu(lambda: bullet.step(0.0, 0.0), repeats),
        }
    kin.true_ranges()
    out["lidar_kinematic_us"] = 1e6 * best_cpu(kin.true_ranges, repeats)
    out["step_kinematic_us"] = 1e6 * best_cpu(lambda: kin.step(0.0, 0.0), repeats)
    return out


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default="BARN-0,BARN-150,BARN-299,R1,R2,R3", help="comma list")
    ap.add_argument("--methods", default="dwa3,d3dwa", help="comma list")
    ap.add_argument("--repeats", type=int, default=1, help="timed episodes per backend and cell")
    ap.add_argument("--parts-repeats", type=int, default=20, help="timings of the parts, best kept")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.parts_repeats < 1:
        ap.error("--repeats and --parts-repeats must be >= 1")
    worlds = [load_world(name) for name in args.worlds.split(",")]
    methods = args.methods.split(",")
    cells: list[dict[str, Any]] = []
    for world in worlds:
        for method in methods:
            for backend in BACKENDS:  # warm-up: imports, policy, numba
                episode_cpu(world, method, backend)
            cpu = {b: 0.0 for b in BACKENDS}
            steps = {b: 0 for b in BACKENDS}
            outcome = {}
            for _ in range(args.repeats):
                for backend in BACKENDS:
                    spent, n, outcome[backend] = episode_cpu(world, method, backend)
                    cpu[backend] += spent / args.repeats
                    steps[backend] = n
            cells.append({"world": world.name, "method": method, "cpu_s": cpu, "steps": steps,
                          "outcome": outcome, "ratio": cpu["pybullet"] / cpu["kinematic"]})  # fmt: skip
    total = {b: sum(c["cpu_s"][b] for c in cells) for b in BACKENDS}
    nsteps = {b: sum(c["steps"][b] for c in cells) for b in BACKENDS}
    summary: dict[str, Any] = {
        "episodes_per_backend": len(cells),
        "cpu_s": total,
        "ratio_per_episode": total["pybullet"] / total["kinematic"],
        "ratio_per_step": (total["pybullet"] / nsteps["pybullet"])
        / (total["kinematic"] / nsteps["kinematic"]),
        "outcomes_equal": sum(c["outcome"]["pybullet"] == c["outcome"]["kinematic"] for c in cells),
        "parts": {w.name: parts(w, args.parts_repeats) for w in worlds[:1]},
    }
    if args.json:
        print(json.dumps({"cells": cells, "summary": summary}, indent=1))
        return
    for c in cells:
        print(f"{c['world']:>10} {c['method']:>6}: PyBullet {c['cpu_s']['pybullet']:6.2f} s "
              f"({c['steps']['pybullet']} steps, {c['outcome']['pybullet']}), kinematic "
              f"{c['cpu_s']['kinematic']:6.2f} s ({c['steps']['kinematic']} steps, "
              f"{c['outcome']['kinematic']}): {c['ratio']:.1f}x")  # fmt: skip
    print(f"all {len(cells)} episodes: PyBullet {total['pybullet']:.1f} s CPU, kinematic "
          f"{total['kinematic']:.1f} s: {summary['ratio_per_episode']:.2f}x per episode, "
          f"{summary['ratio_per_step']:.2f}x per step; {summary['outcomes_equal']} of {len(cells)} "
          "outcomes equal")  # fmt: skip
    for name, part in summary["parts"].items():
        print(f"{name}: lidar {part['lidar_pybullet_us']:.0f} us (rayTestBatch) vs {part['lidar_kinematic_us']:.0f} "
              f"us (numba); a step's motion {part['step_pybullet_us']:.0f} us (Bullet) vs "
              f"{part['step_kinematic_us']:.1f} us (kinematic)")  # fmt: skip


if __name__ == "__main__":
    raise SystemExit(main())
