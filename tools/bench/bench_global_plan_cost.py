"""The global plan's cost per control step and per replan, as ratios against the same episodes
without it (docs/benchmarks.md, docs/design/global-plan.md).

Runs one method on BARN worlds, each episode once without a global plan and once with
``--global-plan scan`` (and ``map`` with ``--map``, ``scan+sight``, the ``sight`` carrot, with
``--sight``), alternating so a busy machine slows both
alike, all with the recovery layer and no noise. Prints the wall-clock seconds per control step
of each, their ratio, the seconds per replan and per-step update of the plan, and the replan's
cost as a fraction of one control step without the plan.

    python -m tools.bench.bench_global_plan_cost --json
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from dataclasses import replace

from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.evaluation.jobs import Job, run_job
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams
from d3dwa_bullet.world.barn import barn_world
from tools.entry import ToolParser, tool_main


def bench(method: str, worlds: Sequence[int], kinds: Sequence[str]) -> dict:
    """kinds: plan names (``scan``, ``map``, ``scan+sight``: a kind with an optional carrot rule)."""
    base = EpisodeConfig(recovery=recovery_params("nav2"))
    configs = {"none": base} | {k: replace(base, global_plan=plan_params(k)) for k in kinds}
    wall = {k: 0.0 for k in configs}
    steps = {k: 0 for k in configs}
    plan = {k: [0.0, 0.0, 0] for k in kinds}  # update seconds, replan seconds, replans
    for index in worlds:
        job = Job(barn_world(index), method, 0)
        for name, config in configs.items():
            t0 = time.perf_counter()
            result = run_job(job, config)
            wall[name] += time.perf_counter() - t0
            steps[name] += result.steps
            if name != "none":
                seconds = result.log["plan_seconds"]
                plan[name][0] += float(seconds[0])
                plan[name][1] += float(seconds[1])
                plan[name][2] += int(result.log["plan_replans"])
    per_step = {k: wall[k] / max(steps[k], 1) for k in configs}
    out: dict = {"method": method, "worlds": list(worlds), "steps": steps}
    out["seconds_per_step"] = {k: round(v, 5) for k, v in per_step.items()}
    for k in kinds:
        update_s, replan_s, replans = plan[k]
        out[k] = {
            "step_ratio_vs_none": round(per_step[k] / per_step["none"], 3),
            "replans": replans,
            "seconds_per_replan": round(replan_s / max(replans, 1), 5),
            "replan_in_steps_without": round(replan_s / max(replans, 1) / per_step["none"], 3),
            "plan_seconds_per_step": round(update_s / max(steps[k], 1), 5),
            "plan_share_of_step": round(update_s / wall[k], 3),
        }
    return out


def plan_params(name: str) -> GlobalPlanParams:
    """The GlobalPlanParams of a plan name (``scan``, ``map``, ``scan+sight``)."""
    kind, _, carrot = name.partition("+")
    return GlobalPlanParams(kind=kind, carrot=carrot or "along")


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--method", default="dwa3")
    ap.add_argument("--worlds", default="0,60,120,180,240", help="BARN world indices")
    ap.add_argument("--map", action="store_true", help="also time --global-plan map")
    ap.add_argument(
        "--sight", action="store_true", help="also time --global-plan scan --carrot sight"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    kinds: tuple[str, ...] = ("scan", "map") if args.map else ("scan",)
    kinds += ("scan+sight",) if args.sight else ()
    out = bench(args.method, [int(w) for w in args.worlds.split(",")], kinds)
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    raise SystemExit(main())
