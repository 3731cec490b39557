"""What precedes a fallback storm: the scan, the chosen (weights, tau) and the admissible set.

Re-runs episodes of a sweep directory (episodes are deterministic given layout, method,
training seed, episode seed and noise) with the policies, recovery layer and scan filter the
sweep ran (its meta.json; weights whose digest differs from the sweep's are refused) and a
step hook that records, per control step: whether
the planner fell back, how many of its (v, w) samples were admissible, the chosen weights and
horizon, the nearest return the noisy scan shows against the nearest true surface (a *phantom*
step: the scan's nearest return is more than ``PHANTOM_M`` nearer than anything real), and the
observation's nearest sector. A *storm* is a run of at least ``STORM_STEPS`` fallback steps;
its window is the ``WINDOW_S`` seconds before its first step. Prints, per method, the share of
phantom steps, the mean admissible count and the chosen horizons in storm windows against all
planned steps.

    python -m tools.experiments.storm_steps runs/sources-sweep --noise harsh \\
        --methods dwa3,d3dwa,d3dwa-dr --policy-seeds 0
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, run_episode
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import D3DWAError, ResultsError
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.evaluation.policy_runs import method_runs, policy_digests
from d3dwa_bullet.evaluation.results import job_rows, read_meta, recovery_of
from d3dwa_bullet.evaluation.tables import scan_filter_of
from d3dwa_bullet.method_specs import needs_policy
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.planning.actions import PlannerAction
from d3dwa_bullet.planning.planner import PlanResult
from d3dwa_bullet.world.generator import generate_world
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, fail, tool_main

PHANTOM_M = 0.10
STORM_STEPS = 5
WINDOW_S = 3.0
CONTROL_DT = 0.1


def world_of(name: str):
    """A sweep row's world: a shipped world, or a generated layout ``<style>-s<seed>``."""
    style, sep, seed = name.rpartition("-s")
    if sep and style.endswith("-style") and seed.isdigit():
        return generate_world(style, int(seed))
    return load_world(name)


def episode_config(sweep: Path, meta: dict[str, Any]) -> EpisodeConfig:
    """The recovery layer and scan filter a sweep's episodes ran with."""
    recovery = recovery_params(recovery_of(sweep, meta))
    return replace(EpisodeConfig(), recovery=recovery, scan_filter=scan_filter_of(meta))


def policies_of(
    sweep: Path, meta: dict[str, Any], method: str, seeds: set[int]
) -> dict[int | None, str | None]:
    """Per training seed, the policy folder ``method`` drove in the sweep (its ``--policy``,
    else the shipped folder); ResultsError if its weights are not the ones the sweep recorded
    (a folder retrained or replaced since), so no episode is re-run with other weights."""
    if not needs_policy(method):
        return {None: None}
    settings = meta.get("settings", {})
    chosen = ",".join(str(k) for k in sorted(seeds)) or None  # None: one policy, no seeds
    runs = method_runs([method], settings.get("policy"), chosen)
    recorded = settings.get("policy_digests", {})
    for name, digest in policy_digests(runs).items():
        if name in recorded and recorded[name] != digest:
            raise ResultsError(
                f"{sweep}: {name}'s weights are not the ones the sweep ran "
                f"(meta.json policy_digests); re-run the sweep or restore the policy"
            )
    return {run.policy_seed: run.policy for run in runs}


def steps_of(
    row: dict[str, Any], config: EpisodeConfig, policy: str | None
) -> dict[str, np.ndarray]:
    """Per-step records of a sweep row's episode, re-run with the step hook."""
    method, seed = row["method"], int(row["seed"])
    controller = make_controller(method, policy)
    out: dict[str, list[float]] = defaultdict(list)

    def hook(ep: Episode, index: int, action: PlannerAction, plan: PlanResult) -> None:
        scan_min = float(np.hypot(*ep.points.T).min()) if len(ep.points) else np.inf
        planned = len(plan.admissible) > 0
        out["planned"].append(planned)
        out["fallback"].append(plan.fallback)
        out["admissible"].append(float(plan.admissible.sum()) if planned else np.nan)
        out["tau"].append(action.tau)
        out["wp"].append(action.wp)
        out["phantom"].append(scan_min < ep.obstacle_distance - PHANTOM_M)
        out["scan_min"].append(scan_min)
        out["true_min"].append(ep.obstacle_distance)

    noise = make_noise(row["noise"], seed)
    run_episode(world_of(row["world"]), controller, seed, noise=noise,
                noise_name=row["noise"], config=config, on_step=hook)  # fmt: skip
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def storm_onsets(fallback: np.ndarray, min_steps: int = STORM_STEPS) -> list[int]:
    """First step of every run of at least ``min_steps`` consecutive fallback steps."""
    onsets, run = [], 0
    for i, f in enumerate(fallback.astype(bool)):
        run = run + 1 if f else 0
        if run == min_steps:
            onsets.append(i - min_steps + 1)
    return onsets


def summarise(episodes: Sequence[dict[str, np.ndarray]]) -> dict[str, Any]:
    """Storm windows against all planned steps: phantom share, admissible count, horizons."""
    window = int(round(WINDOW_S / CONTROL_DT))
    all_mask, win_mask, storms = [], [], 0
    for s in episodes:
        mask = np.zeros(len(s["fallback"]), dtype=bool)
        for onset in storm_onsets(s["fallback"]):
            mask[max(0, onset - window) : onset] = True
            storms += 1
        planned = s["planned"].astype(bool)
        all_mask.append(planned)
        win_mask.append(mask & planned)
    cat = {k: np.concatenate([s[k] for s in episodes]) for k in episodes[0]}
    every, before = np.concatenate(all_mask), np.concatenate(win_mask)

    def stats(m: np.ndarray) -> dict[str, Any]:
        if not m.any():
            return {"steps": 0}
        taus, counts = np.unique(cat["tau"][m], return_counts=True)
        return {
            "steps": int(m.sum()),
            "fallback": float(cat["fallback"][m].mean()),
            "phantom": float(cat["phantom"][m].mean()),
            "admissible": float(np.nanmean(cat["admissible"][m])),
            "scan_min": float(np.median(cat["scan_min"][m])),
            "true_min": float(np.median(cat["true_min"][m])),
            "tau": {
                f"{t:g}": round(float(c / m.sum()), 3) for t, c in zip(taus, counts, strict=True)
            },
        }

    fallback_steps = every & cat["fallback"].astype(bool)
    return {"episodes": len(episodes), "storms": storms, "all": stats(every),
            "before_storm": stats(before), "fallback_steps": stats(fallback_steps)}  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="storm_steps", description=__doc__.split("\n")[0])
    parser.add_argument("sweep", type=Path)
    parser.add_argument("--noise", required=True, help="the rows' noise label (profile)")
    parser.add_argument("--methods", required=True, help="comma list")
    parser.add_argument("--policy-seeds", default="0", help="training seeds, comma list")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        seeds = {int(s) for s in args.policy_seeds.split(",")}
    except ValueError:
        fail("storm_steps", f"--policy-seeds {args.policy_seeds!r}: not integers")
    try:
        meta = read_meta(args.sweep)
        config = episode_config(args.sweep, meta)
        rows = [r for r in job_rows(args.sweep, meta) if r["noise"] == args.noise]
        report = {}
        for method in args.methods.split(","):
            mine = [r for r in rows if r["method"] == method
                    and (r["policy_seed"] is None or r["policy_seed"] in seeds)]  # fmt: skip
            if not mine:
                raise ResultsError(f"{args.sweep}: no rows of {method!r} under {args.noise!r}")
            policies = policies_of(
                args.sweep,
                meta,
                method,
                {int(r["policy_seed"]) for r in mine if r["policy_seed"] is not None},
            )
            report[method] = summarise(
                [steps_of(r, config, policies[r["policy_seed"]]) for r in mine]
            )
    except D3DWAError as exc:
        fail("storm_steps", str(exc))
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
