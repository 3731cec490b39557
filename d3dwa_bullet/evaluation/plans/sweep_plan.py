"""``d3dwa sweep --plan``: a sweep run look by look under a sequential plan's stopping rule.

The sweep's episodes (``sweep.sweep_jobs``: its worlds x methods x profiles x seeds) are the
source of :func:`~d3dwa_bullet.evaluation.plans.run.run_plan`: at each look it asks for the
episodes of some (layout, profile, method) keys, and ``jobs.evaluate`` runs those not yet in
results.csv (so a stopped run resumes where it was) into the same directory, with the same
meta.json a plain sweep writes (``sweep_meta``). The plan's methods and profiles must be among
the sweep's; its families' strata are the layouts' (``order.stratum_of``: ``barn`` or a style).
A plan whose cells read across global-plan settings runs each setting in its own subdirectory of
out, a plain sweep directory each (``setting_sides.py``; docs/design/sequential-plans.md#across-a-setting).
Not imported by ``plans/__init__``: this module runs episodes (the simulator, the planner).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import Any

from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation.jobs import Job, evaluate
from d3dwa_bullet.evaluation.plans.order import stratum_of
from d3dwa_bullet.evaluation.plans.plan_file import Plan, check_fits
from d3dwa_bullet.evaluation.plans.plan_seeds import with_plan_seeds
from d3dwa_bullet.evaluation.plans.run import Key, code_identity, run_plan
from d3dwa_bullet.evaluation.plans.setting_sides import (
    check_setting_options,
    plan_sides,
    setting_dirs,
    side_source,
)
from d3dwa_bullet.evaluation.results import row_key
from d3dwa_bullet.evaluation.reuse import Reuse
from d3dwa_bullet.evaluation.same_run import check_resumable
from d3dwa_bullet.evaluation.sweep import SWEEP_FIELDS, read_sweep, sweep_jobs
from d3dwa_bullet.evaluation.sweep_meta import sweep_meta
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.planning.global_plan_params import global_plan_params


def _layout(job: Job) -> dict[str, Any]:
    return {"world": job.world.name, **dict(job.columns)}


class _SettingRun:
    """One setting's episodes in one sweep directory: checked resumable (under its lock, held by
    the caller), then each call runs the jobs of the keys given (with every job the directory
    already held, so it is resumed, never refused as holding others) and returns their rows."""

    def __init__(self, out: Path, config: EpisodeConfig, meta: dict[str, Any], jobs: Sequence[Job],
                 methods: Sequence[str], run: dict[str, Any]) -> None:  # fmt: skip
        check_resumable(out, SWEEP_FIELDS, config, meta, methods)
        self.out, self.config, self.meta, self.run = out, config, meta, run
        self.by_key: dict[Key, list[Job]] = defaultdict(list)
        for j in jobs:
            self.by_key[(j.world.name, j.noise, j.method)].append(j)
        # episodes already in out (a later look of a killed run, a sweep run before)
        held = {row_key(r) for r in read_sweep(out)} if (out / "results.csv").exists() else set()
        self.before = [j for j in jobs if j.key in held]

    def __call__(self, keys: Sequence[Key]) -> list[dict[str, Any]]:
        chosen = [j for k in keys for j in self.by_key.get(k, ())]
        listed = list({j.key: j for j in [*self.before, *chosen]}.values())
        evaluate(
            listed,
            self.out,
            config=self.config,
            fields=SWEEP_FIELDS,
            settings=self.meta,
            **self.run,
        )
        wanted = {j.key for j in chosen}
        return [r for r in read_sweep(self.out) if row_key(r) in wanted]


def run_plan_sweep(
    settings: SweepSettings, plan: Plan, out: str | Path, workers: int = 1, ray_address: str | None = None,
    config: EpisodeConfig = EpisodeConfig(), progress: bool = True, policy: str | None = None,
    command: str = "", reuse: Reuse | None = None,
) -> list[dict[str, Any]]:  # fmt: skip
    """Run the sweep of settings under plan into out; returns the looks' records
    (``run.run_plan``). The profile ``none`` is the sweep's noise-free baseline; a plan with
    ``seeds`` runs each learned method's seeds it names (``plan_seeds.with_plan_seeds``). A
    cell with ``global_plan`` runs each side under its setting, config's global plan replaced,
    in out's subdirectory of that setting (``setting_sides.setting_dirs``); the others under
    config's."""
    check_fits(plan, settings.methods, settings.profiles)
    default = config.global_plan_name
    check_setting_options(plan, default, reuse is not None)
    settings = with_plan_seeds(settings, plan, policy)
    out = Path(out)
    dirs = {s: out / name for s, name in setting_dirs(plan, default).items()} or {default: out}
    run = {"workers": workers, "progress": progress, "ray_address": ray_address, "reuse": reuse}
    with ExitStack() as stack:
        stack.enter_context(locked_dir(out))
        configs, metas = {}, {}
        for setting, where in dirs.items():
            if where != out:
                stack.enter_context(locked_dir(where))
            same = setting == default  # the sweep's own plan, with whatever parameters it has
            configs[setting] = (
                config if same else replace(config, global_plan=global_plan_params(setting))
            )
            metas[setting], _ = sweep_meta(settings, configs[setting], policy, command)
        jobs = [j for j in sweep_jobs(settings, policy, progress) if j.noise in plan.profiles]
        strata = {j.world.name: str(stratum_of(_layout(j))) for j in jobs}
        runs = {s: _SettingRun(where, configs[s], metas[s], jobs, settings.methods, run)
                for s, where in dirs.items()}  # fmt: skip
        source = side_source(plan_sides(plan, default), lambda s, keys: runs[s](keys))
        return run_plan(plan, strata, source, out, code_identity())
