"""Probe what the action set can do in a world: every fixed action, and a map-aware oracle.

For each world, runs one noise-free episode per action of the set with that action held at
every step, and one episode of the greedy geodesic oracle (:mod:`tools.experiments.oracle`),
which plans with every action at every step and keeps the one whose command ends nearest the
goal along the inflated map. A world that neither reaches says the DWA with these (weights, tau)
choices is stuck there, whatever a policy learns; one that only the oracle reaches needs
state-dependent switching; one that many fixed actions reach is a learning problem.

    python -m tools.experiments.probe_actions TS4 H2                  # fixed actions + oracle
    python -m tools.experiments.probe_actions --no-fixed --workers 2  # the oracle on every world
    python -m tools.experiments.probe_actions R2 --actions weights --json

Prints a table (or JSON with ``--json``); exit status 2 on bad input.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from typing import Any

from tqdm import tqdm

from d3dwa_bullet.backends import run_local
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.world.registry import list_worlds, load_world
from tools.entry import ToolParser, fail, tool_main
from tools.experiments.oracle import ORACLE, fixed_action_outcome, run_oracle

ACTION_SETS = {"full": ACTIONS_FULL, "weights": ACTIONS_WEIGHTS_ONLY}


def run_job(job: tuple[str, str, int], config: tuple[str, int]) -> tuple[Any, dict[str, Any]]:
    """One probe episode; job = (world, "fixed" | "oracle", action index), config = (set, seed)."""
    world_name, kind, index = job
    set_name, seed = config
    world, actions = load_world(world_name), ACTION_SETS[set_name]
    if kind == ORACLE:
        result = run_oracle(world, actions, seed)
    else:
        result = fixed_action_outcome(world, actions, index, seed)
    final = [round(float(result.log[k][-1]), 3) for k in ("x", "y")] if result.steps else None
    return job, result.summary() | {"final_xy": final}


def probe(
    worlds: Sequence[str], set_name: str = "full", fixed: bool = True, seed: int = 0,
    workers: int = 1, progress: bool = True,
) -> list[dict[str, Any]]:  # fmt: skip
    """One row per world: fixed actions that reach the goal, the fastest of them, the oracle."""
    actions = ACTION_SETS[set_name]
    jobs = [(w, ORACLE, -1) for w in worlds]
    if fixed:
        jobs += [(w, "fixed", i) for w in worlds for i in range(len(actions))]
    done: dict[tuple[str, str, int], dict[str, Any]] = {}
    summary: dict[str, Any]
    with tqdm(total=len(jobs), disable=not progress, unit="ep", desc="probe") as bar:
        for job, summary in run_local(run_job, jobs, (set_name, seed), workers):
            done[job] = summary
            bar.update()
    rows = []
    for w in worlds:
        oracle = done[(w, ORACLE, -1)]
        row: dict[str, Any] = {
            "world": w,
            "oracle": oracle["outcome"],
            "oracle_time_s": oracle["time_s"] if oracle["outcome"] == "goal" else None,
            "oracle_final_xy": oracle["final_xy"],
        }
        if fixed:
            reached = sorted(
                (done[(w, "fixed", i)]["time_s"], i)
                for i in range(len(actions))
                if done[(w, "fixed", i)]["outcome"] == "goal"
            )
            collided = sum(
                done[(w, "fixed", i)]["outcome"] == "collision" for i in range(len(actions))
            )
            row |= {
                "fixed_goal": len(reached),
                "fixed_collision": collided,
                "fixed_total": len(actions),
                "fixed_reaching": [i for _, i in reached],
                "fastest_fixed": (
                    {"action": reached[0][1], "tuple": list(actions.decode(reached[0][1])),
                     "time_s": reached[0][0]} if reached else None
                ),
            }  # fmt: skip
        rows.append(row)
    return rows


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    head = f"{'world':<8} {'fixed actions reaching':>22} {'fastest fixed (wp,wc,ws,tau)':>32} {'oracle':>26}"
    lines = [head, "-" * len(head)]
    for r in rows:
        if r["oracle"] == "goal":
            oracle = f"goal {r['oracle_time_s']:.1f} s"
        else:
            oracle = (
                f"{r['oracle']} at ({r['oracle_final_xy'][0]:.2f}, {r['oracle_final_xy'][1]:.2f})"
            )
        if "fixed_goal" in r:
            fixed = f"{r['fixed_goal']}/{r['fixed_total']} ({r['fixed_collision']} C)"
            best = r["fastest_fixed"]
            fastest = (
                f"{tuple(int(x) if x == int(x) else x for x in best['tuple'])} {best['time_s']:.1f} s"
                if best else "-"
            )  # fmt: skip
        else:
            fixed, fastest = "-", "-"
        lines.append(f"{r['world']:<8} {fixed:>22} {fastest:>32} {oracle:>26}")
    lines.append(
        "fixed: one noise-free episode per action held constant; oracle: greedy choice among "
        "all actions by shortest route (privileged map) from each command's arc end"
    )
    return "\n".join(lines)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("worlds", nargs="*", help="world names or files (default: every shipped world)")
    ap.add_argument("--actions", choices=sorted(ACTION_SETS), default="full", help="action set")
    ap.add_argument("--no-fixed", action="store_true", help="only the oracle")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1, help="local processes")
    ap.add_argument("--json", action="store_true", help="print a JSON list of rows")
    args = ap.parse_args(argv)
    try:
        worlds = args.worlds or [w.name for w in list_worlds()]
        for w in worlds:
            load_world(w)
    except D3DWAError as err:
        fail("probe_actions", str(err))
    rows = probe(worlds, args.actions, not args.no_fixed, args.seed, args.workers,
                 progress=not args.json)  # fmt: skip
    print(json.dumps(rows, indent=2) if args.json else format_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
