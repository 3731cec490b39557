"""Is a greedy stall a dead end of the planner, or a choice the learner got wrong?

    python -m tools.experiments.dead_end docs/pilots/d3dwa-dp-b/seed-2 --world R2 --at 20

Runs the policy's greedy episode on ``--world`` (no noise, episode seed 0) for ``--at``
decisions, then, from that same state (the episode is replayed from its start each time, so
every branch starts from the identical state), holds one action for ``--hold`` decisions and
lets the greedy policy go on for up to ``--then`` more. Per action it prints how far the robot
got towards the goal and how the branch ended, beside the action's Q at the branch point.
If no action moves the robot, no chooser of (weights, tau) can leave the state: its true value
is the step penalty's, whatever the network says (docs/history.md#learner).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.learning.agents.policy import all_q_values, greedy_policy
from d3dwa_bullet.learning.training.config import make_env
from tools.entry import ToolParser, fail, tool_main
from tools.experiments.value_check import load

MOVED = 0.1
"""Metres towards the goal a branch must make to count as leaving the state."""


def branches(
    path: Path, world: str, at: int, hold: int, then: int, actions: list[int] | None
) -> dict[str, Any]:
    agent, config = load(path)
    env = make_env(config, worlds=(world,), allow_eval_worlds=True)
    policy = greedy_policy(agent)

    def branch_point() -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = env.reset(options={"world": world, "noise": "none", "episode_seed": 0})
        for t in range(at):
            obs, _, terminated, truncated, info = env.step(policy(obs))
            if terminated or truncated:
                raise D3DWAError(f"--at {at}: the greedy episode ended at decision {t + 1}")
        return obs, info

    try:
        obs0, info0 = branch_point()
        q0 = all_q_values(agent, obs0[None])[0]
        tried = list(range(len(q0))) if actions is None else actions
        for a in tried:  # all checked before any branch is replayed
            if not 0 <= a < len(q0):
                raise D3DWAError(f"--actions: {a} is not an action index 0..{len(q0) - 1}")
        rows: list[dict[str, Any]] = []
        for a in tried:
            obs, info = branch_point()
            outcome = None
            for k in range(hold + then):
                obs, _, terminated, truncated, info = env.step(a if k < hold else policy(obs))
                if terminated or truncated:
                    outcome = info["outcome"]
                    break
            rows.append({
                "action": a, "q": float(q0[a]), "outcome": outcome or "running",
                "towards_goal_m": float(info0["goal_distance"] - info["goal_distance"]),
            })  # fmt: skip
    finally:
        env.close()
    return {
        "policy": str(path), "world": world, "at": at, "hold": hold, "then": then,
        "goal_distance_m": float(info0["goal_distance"]), "greedy": int(q0.argmax()),
        "q_spread": float(q0.max() - q0.min()), "branches": rows,
        "moved": sum(r["towards_goal_m"] > MOVED for r in rows),
        "goals": sum(r["outcome"] == "goal" for r in rows),
    }  # fmt: skip


def describe(result: dict[str, Any]) -> str:
    qs = [r["q"] for r in result["branches"]]
    return (
        f"{result['policy']} on {result['world']}, decision {result['at']}: "
        f"{result['goal_distance_m']:.2f} m from the goal, greedy action {result['greedy']}; "
        f"Q over the actions tried {min(qs):.3f}..{max(qs):.3f}.\n"
        f"holding each of {len(qs)} actions {result['hold']} decisions, then greedy for "
        f"{result['then']}: {result['moved']} got more than {MOVED} m closer, "
        f"{result['goals']} reached the goal"
    )


@tool_main
def main(argv: list[str] | None = None) -> int:
    ap = ToolParser(prog="python -m tools.experiments.dead_end")
    ap.add_argument("policy", type=Path, help="a policy folder (with config.json beside meta.json)")
    ap.add_argument("--world", required=True)
    ap.add_argument("--at", type=int, required=True, help="decisions of the greedy episode first")
    ap.add_argument("--hold", type=int, default=5, help="decisions each action is held")
    ap.add_argument("--then", type=int, default=25, help="greedy decisions after the hold")
    ap.add_argument("--actions", default=None, help="e.g. 0,50,99 (default: every action)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        actions = None if args.actions is None else [int(a) for a in args.actions.split(",")]
    except ValueError:
        print(
            f"dead_end: error: --actions {args.actions!r}: expected e.g. 0,50,99", file=sys.stderr
        )
        return 2
    if args.at < 0 or args.hold < 1 or args.then < 0:
        print("dead_end: error: --at and --then must be >= 0, --hold >= 1", file=sys.stderr)
        return 2
    try:
        result = branches(args.policy, args.world, args.at, args.hold, args.then, actions)
    except (D3DWAError, OSError) as err:
        fail("dead_end", str(err))
    print(json.dumps(result, indent=1) if args.json else describe(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
