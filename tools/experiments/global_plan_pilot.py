"""What should a learned policy's goal distance read under a global plan? A pilot of both choices.

The shipped policies were trained without a global plan; under one they read the carrot as their
goal (docs/design/global-plan.md). Their goal distance can be the carrot's distance or the path
length left to the goal (on the carrot's bearing either way). This pilot runs one policy (seed 0 of
a learned method) with ``--recovery nav2 --global-plan scan`` and no noise on BARN *train* worlds
(never the challenge worlds the results are read on), once with each choice, and prints the
successes and the mean time of the episodes both reached.

    python -m tools.experiments.global_plan_pilot --json
"""

from __future__ import annotations

import argparse
import json
import statistics
from collections.abc import Sequence
from dataclasses import replace

from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.evaluation.jobs import Job, run_job
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.planning.global_plan_params import GOAL_DISTANCES, GlobalPlanParams
from d3dwa_bullet.world.barn import barn_split_ids, barn_world
from tools.entry import ToolParser, tool_main


def pilot(method: str, worlds: Sequence[int]) -> dict:
    policy = str(default_policy_path(method) / "seed-0")
    base = EpisodeConfig(recovery=recovery_params("nav2"))
    out: dict = {"method": method, "policy": policy, "worlds": list(worlds), "by_choice": {}}
    times: dict[str, dict[int, float]] = {}
    for choice in GOAL_DISTANCES:
        config = replace(base, global_plan=GlobalPlanParams(kind="scan", goal_distance=choice))
        outcomes, times[choice] = {}, {}
        for index in worlds:
            result = run_job(
                Job(barn_world(index), method, 0, policy=policy, policy_seed=0), config
            )
            outcomes[index] = result.outcome
            if result.outcome == "goal":
                times[choice][index] = result.time_s
            print(f"{choice} BARN-{index}: {result.outcome} {result.time_s:.1f} s", flush=True)
        out["by_choice"][choice] = {
            "goals": sum(o == "goal" for o in outcomes.values()),
            "outcomes": outcomes,
        }
    both = sorted(set.intersection(*(set(t) for t in times.values())))
    for choice in GOAL_DISTANCES:
        mean = statistics.mean(times[choice][i] for i in both) if both else None
        out["by_choice"][choice]["mean_time_s_where_both_reached"] = mean
    out["both_reached"] = len(both)
    return out


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--method", default="d3dwa")
    ap.add_argument("--count", type=int, default=10, help="BARN train worlds, evenly spaced")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    train = barn_split_ids("train")
    step = max(1, len(train) // args.count)
    out = pilot(args.method, train[::step][: args.count])
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    raise SystemExit(main())
