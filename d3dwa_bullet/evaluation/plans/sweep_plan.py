"""``d3dwa sweep --plan``: a sweep run look by look under a sequential plan's stopping rule.

The sweep's episodes (``sweep.sweep_jobs``: its worlds x methods x profiles x seeds) are the
source of :func:`~d3dwa_bullet.evaluation.plans.run.run_plan`: at each look it asks for the
episodes of some (layout, profile, method) keys, and ``jobs.evaluate`` runs those not yet in
results.csv (so a stopped run resumes where it was) into the same directory, with the same
meta.json a plain sweep writes (``sweep_meta``). The plan's methods and profiles must be among
the sweep's; its families' strata are the layouts' (``order.stratum_of``: ``barn`` or a style).
Not imported by ``plans/__init__``: this module runs episodes (the simulator, the planner).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation.jobs import Job, evaluate
from d3dwa_bullet.evaluation.plans.order import stratum_of
from d3dwa_bullet.evaluation.plans.plan_file import Plan, check_fits
from d3dwa_bullet.evaluation.plans.plan_seeds import with_plan_seeds
from d3dwa_bullet.evaluation.plans.run import Key, code_identity, run_plan
from d3dwa_bullet.evaluation.results import row_key
from d3dwa_bullet.evaluation.reuse import Reuse
from d3dwa_bullet.evaluation.same_run import check_resumable
from d3dwa_bullet.evaluation.sweep import SWEEP_FIELDS, read_sweep, sweep_jobs
from d3dwa_bullet.evaluation.sweep_meta import sweep_meta
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings


def _layout(job: Job) -> dict[str, Any]:
    return {"world": job.world.name, **dict(job.columns)}


def run_plan_sweep(
    settings: SweepSettings, plan: Plan, out: str | Path, workers: int = 1, ray_address: str | None = None,
    config: EpisodeConfig = EpisodeConfig(), progress: bool = True, policy: str | None = None,
    command: str = "", reuse: Reuse | None = None,
) -> list[dict[str, Any]]:  # fmt: skip
    """Run the sweep of settings under plan into out; returns the looks' records
    (``run.run_plan``). The profile ``none`` is the sweep's noise-free baseline; a plan with
    ``seeds`` runs each learned method's seeds it names (``plan_seeds.with_plan_seeds``)."""
    check_fits(plan, settings.methods, settings.profiles)
    settings = with_plan_seeds(settings, plan, policy)
    out = Path(out)
    meta, _ = sweep_meta(settings, config, policy, command)
    with locked_dir(out):
        check_resumable(out, SWEEP_FIELDS, config, meta, settings.methods)
        jobs = [j for j in sweep_jobs(settings, policy, progress) if j.noise in plan.profiles]
        by_key: dict[Key, list[Job]] = defaultdict(list)
        strata: dict[str, str] = {}
        for j in jobs:
            by_key[(j.world.name, j.noise, j.method)].append(j)
            strata[j.world.name] = str(stratum_of(_layout(j)))

        # episodes already in out (a later look of a killed run, a sweep run before) are listed
        # with every look's jobs, so the directory is resumed, never refused as holding others
        held = {row_key(r) for r in read_sweep(out)} if (out / "results.csv").exists() else set()
        before = [j for j in jobs if j.key in held]

        def source(keys: Sequence[Key]) -> list[dict[str, Any]]:
            chosen = [j for k in keys for j in by_key.get(k, ())]
            listed = list({j.key: j for j in [*before, *chosen]}.values())
            evaluate(listed, out, workers, config, progress, ray_address, SWEEP_FIELDS, meta, reuse)
            wanted = {j.key for j in chosen}
            return [r for r in read_sweep(out) if row_key(r) in wanted]

        return run_plan(plan, strata, source, out, code_identity())
