"""Benchmark full control steps (physics + lidar + estimator + observation + planner).

Runs DWA III (fixed weights, tau = 4 s) in DIRECT mode on a few shipped worlds and reports
control steps per wall-clock second, excluding simulator start-up, and per CPU-second of
this process (the figure that stays meaningful when other work shares the cores). The
whole run is repeated (--repeats, default 3) and the median repeat is reported, with the
slowest and fastest beside it: on a shared virtual machine single runs vary by +-10 %.

``--recovery nav2`` runs the episodes with the recovery layer; ``--recovery both`` runs every
repeat without and with it, alternating, and reports the cost ratio (with / without, per
control step, wall and CPU) measured in this one run. The recovery layer only acts where a
robot stalls, so ``--worlds`` should hold some where DWA III does (US1, TS4, H2).

    python -m tools.bench.bench_env --json
    python -m tools.bench.bench_env --recovery both --worlds TS1,US1,TS4,H2 --steps 600 --json

``--train-env CONFIG`` also steps one training env of that config (its worlds, curriculum,
noise recipe and observation; uniformly random actions from a fixed seed, resetting when an
episode ends) for as many steps, alternating with the bare runs, and reports its steps per
second and per CPU-second beside them: is the env the training loop drives dearer than the
bare simulator, or is the gap in the loop around it?

    python -m tools.bench.bench_env --train-env configs/d3dwa-dr.yaml --json
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from typing import cast

from gymnasium.spaces import Discrete

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, EpisodeConfig
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main

DEFAULT_WORLDS = ["TS1", "TS3", "H1", "R3"]
"""The worlds of a bench run unless --worlds names others."""


def bench(worlds: list[str], steps: int, method: str, recovery: str = "none") -> dict:
    controller = make_controller(method)
    config = EpisodeConfig(recovery=recovery_params(recovery))
    total_steps, total_time, total_cpu = 0, 0.0, 0.0
    for name in worlds:
        with Episode(load_world(name), config=config) as ep:
            controller.reset(ep.seed)
            t0, c0 = time.perf_counter(), time.process_time()
            n = 0
            while n < steps:
                obs = ep.observe()
                if ep.outcome is not None:
                    break
                ep.act(*controller(obs))
                n += 1
            total_time += time.perf_counter() - t0
            total_cpu += time.process_time() - c0
            total_steps += n
    return {
        "steps_per_s": round(total_steps / total_time, 1),
        "steps_per_cpu_s": round(total_steps / total_cpu, 1),
        "steps": total_steps,
        "worlds": worlds,
        "method": method,
        "recovery": recovery,
        "real_time_factor": round(total_steps * 0.1 / total_time, 1),
    }


def bench_train_env(config: str, steps: int) -> dict:
    """steps control steps of one training env of ``config``, random actions (seed 0)."""
    import numpy as np

    from d3dwa_bullet.learning.training import load_train_config
    from d3dwa_bullet.learning.training.config import make_env

    env = make_env(load_train_config(config))
    rng = np.random.default_rng(0)
    try:
        env.reset(seed=0)
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(
                int(rng.integers(cast(Discrete, env.action_space).n))
            )
            if terminated or truncated:
                env.reset()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        env.close()
    return {"steps_per_s": round(steps / wall, 1), "steps_per_cpu_s": round(steps / cpu, 1),
            "steps": steps, "config": config}  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default=",".join(DEFAULT_WORLDS), help="comma list of worlds")
    ap.add_argument("--steps", type=int, default=300, help="max control steps per world")
    ap.add_argument("--method", default="dwa3")
    ap.add_argument("--repeats", type=int, default=3, help="whole runs; the median is reported")
    ap.add_argument("--recovery", default="none", choices=("none", "nav2", "both"))
    ap.add_argument("--train-env", metavar="CONFIG", help="also step a training env of CONFIG")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    worlds = args.worlds.split(",")
    kinds = ("none", "nav2") if args.recovery == "both" else (args.recovery,)
    runs: dict[str, list[dict]] = {k: [] for k in (*kinds, "train_env")}
    for _ in range(args.repeats):  # alternating, so a busy spell hits both alike
        for kind in kinds:
            runs[kind].append(bench(worlds, args.steps, args.method, kind))
            if args.train_env:
                n = runs[kind][-1]["steps"]
                runs["train_env"].append(bench_train_env(args.train_env, n))
    summary = {}
    for kind, rs in ((k, rs) for k, rs in runs.items() if rs):
        rs.sort(key=lambda r: r["steps_per_s"])
        summary[kind] = rs[len(rs) // 2] | {
            "repeats": args.repeats,
            "slowest_steps_per_s": rs[0]["steps_per_s"],
            "fastest_steps_per_s": rs[-1]["steps_per_s"],
        }
    if args.recovery == "both":
        off, on = summary["none"], summary["nav2"]
        out = {
            "off": off,
            "on": on,
            "cost_ratio_wall": round(off["steps_per_s"] / on["steps_per_s"], 3),
            "cost_ratio_cpu": round(off["steps_per_cpu_s"] / on["steps_per_cpu_s"], 3),
        }
    else:
        out = summary[kinds[0]]
    if args.train_env:
        train_env, bare = summary["train_env"], summary[kinds[0]]
        out = {
            "bare": bare,
            "train_env": train_env,
            "train_env_vs_bare_cpu": round(
                train_env["steps_per_cpu_s"] / bare["steps_per_cpu_s"], 3
            ),
            "train_env_vs_bare_wall": round(train_env["steps_per_s"] / bare["steps_per_s"], 3),
        }
    print(json.dumps(out) if args.json else "\n".join(f"{k:>16}: {v}" for k, v in out.items()))


if __name__ == "__main__":
    raise SystemExit(main())
