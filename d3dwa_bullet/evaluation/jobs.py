"""Evaluate methods on worlds over seeds: independent episodes, spread over processes.

A :class:`~d3dwa_bullet.evaluation.job.Job` is one episode (world, method, seed, noise);
:func:`evaluate` runs every job
of a list not yet in a results directory (see :mod:`d3dwa_bullet.evaluation.results` for
what the directory holds and how a run resumes) and returns the rows of the whole list.

Episodes run in this process, in a pool of spawned processes (``workers``) or on a Ray
cluster (``ray_address``, see :mod:`d3dwa_bullet.backends`), with identical rows;
results.csv ends up in job order either way.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from d3dwa_bullet.backends import open_backend
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.episode import EpisodeConfig, EpisodeResult, run_episode
from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.job import Job, log_name
from d3dwa_bullet.evaluation.policy_runs import check_scan_filters
from d3dwa_bullet.evaluation.repeats import kept_keys
from d3dwa_bullet.evaluation.results import (
    CSV_FIELDS,
    DERIVED_PAGES,
    Key,
    appending_rows,
    check_results_dir,
    drop_partial_row,
    load_log,
    order_results,
    read_results,
    row_key,
    save_log,
    write_meta,
)
from d3dwa_bullet.evaluation.reuse import (
    DIGESTS_KEY,
    REUSED_KEY,
    Reuse,
    plan_reuse,
    reused_record,
    world_digests,
)
from d3dwa_bullet.evaluation.same_run import check_same_run, run_fields, run_settings
from d3dwa_bullet.evaluation.scores import add_scores, needs_scores
from d3dwa_bullet.io import file_stem
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.sim.backend import check_backend_worlds
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.noise_config import NoiseConfig
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.routes import official_length, reference_length
from randomization import episode_noise, load_profile


def row_log_path(out: Path, row: Mapping[str, Any]) -> Path:
    """Where results directory ``out`` keeps the per-step log of the episode a results.csv
    ``row`` records (it may be missing: an episode taken with --reuse has none)."""
    return out / "logs" / log_name(row_key(row))


def row_log(out: Path, row: Mapping[str, Any]) -> dict[str, Any]:
    """The per-step log of the episode a results.csv ``row`` of results directory ``out``
    records; ResultsError (one line, the file) if it is missing."""
    path = row_log_path(out, row)
    if not path.is_file():
        raise ResultsError(f"{path}: log of the episode is missing")
    return load_log(path)


def figure_name(world: str, colour_by: str) -> str:
    """The file name, in a results directory's figures/, of a world's trajectories coloured
    by ``colour_by`` (time, tau): ``TS1_time.png``; a world name that is not a safe file
    name (``../../escape``, 300 characters) is made one (:func:`~d3dwa_bullet.io.file_stem`)."""
    return f"{file_stem(world)}_{colour_by}.png"


def make_noise(profile: str, seed: int):
    """The NoiseModel of an episode under a named profile (None for 'none')."""
    if profile == "none":
        return None
    return episode_noise(load_profile(profile), seed)


def noise_config_json(config: NoiseConfig) -> str:
    """The Job.noise_config string of a NoiseConfig (canonical: sorted keys)."""
    return json.dumps(config.to_dict(), sort_keys=True)


def job_noise(job: Job) -> NoiseModel | None:
    """The NoiseModel of a job: its explicit config, else its profile, else None."""
    if job.noise_config is not None:
        config = parse_json(job.noise_config, ConfigError, "Job.noise_config")
        return NoiseModel(NoiseConfig.from_dict(config), job.seed)
    return make_noise(job.noise, job.seed)


def run_job(job: Job, config: EpisodeConfig = EpisodeConfig()) -> EpisodeResult:
    """Run one job in this process."""
    controller = make_controller(job.method, job.policy)
    return run_episode(
        job.world, controller, seed=job.seed, noise=job_noise(job),
        noise_name=job.noise, config=config,
    )  # fmt: skip


def _worker(job: Job, config: EpisodeConfig) -> tuple[Job, EpisodeResult]:
    return job, run_job(job, config)


def evaluate(
    jobs: Sequence[Job],
    out: str | os.PathLike[str],
    workers: int = 1,
    config: EpisodeConfig = EpisodeConfig(),
    progress: bool = True,
    ray_address: str | None = None,
    fields: Sequence[str] = CSV_FIELDS,
    settings: dict[str, Any] | None = None,
    reuse: Reuse | None = None,
) -> list[dict[str, Any]]:
    """Run every job not already in out/results.csv; returns all rows for these jobs.

    workers: local processes (1 = this process). ray_address: run on Ray instead (see
    :mod:`d3dwa_bullet.backends`). fields: the CSV columns (CSV_FIELDS plus the
    jobs' extra columns). settings: what the command was (kind, methods, worlds, ...), kept
    in meta.json for ``d3dwa report``. A job that repeats its episode at every evaluation
    seed (no noise, a fixed or learned method: :mod:`~d3dwa_bullet.evaluation.repeats`) runs
    at the first seed of its (world, method, training seed, noise) only: its other seeds get
    no episode, no row and no key in meta.json (a directory from before that holds their
    rows is resumed; the rows are left in results.csv and not returned). Rows are appended as episodes finish; once every job
    is in, results.csv is rewritten in the order of jobs, whatever the backend. A directory
    whose rows these jobs would not resume or extend is refused before any episode runs
    (ResultsError from :func:`~d3dwa_bullet.evaluation.same_run.check_same_run`), and so is
    one another process is writing (BusyError): the directory is locked
    (:mod:`d3dwa_bullet.dir_lock`) from before its first write to the return. reuse: take
    the episodes another directory provably ran (:mod:`~d3dwa_bullet.evaluation.reuse`).
    """
    with locked_dir(out):
        return _evaluate(
            jobs, Path(out), workers, config, progress, ray_address, fields, settings, reuse
        )  # fmt: skip


def _evaluate(
    jobs: Sequence[Job],
    out: Path,
    workers: int,
    config: EpisodeConfig,
    progress: bool,
    ray_address: str | None,
    fields: Sequence[str],
    settings: dict[str, Any] | None,
    reuse: Reuse | None,
) -> list[dict[str, Any]]:
    recovery, backend, plan = config.recovery_name, config.backend, config.global_plan_name
    fields = run_fields(
        fields, recovery, (j.method for j in jobs), backend=backend, global_plan=plan
    )
    settings = run_settings(settings, recovery, backend=backend, global_plan=plan)
    v_max = config.planner.limits.v_max
    check_distinct(jobs)
    check_backend_worlds(backend, [j.world for j in jobs])
    check_scan_filters(((j.method, j.policy) for j in jobs), config.scan_filter)
    unique: dict[Key, Job] = {}
    for j in jobs:  # a world or seed named twice is one episode, not two rows
        unique.setdefault(j.key, j)
    listed = list(unique)  # a directory from before may hold the repeats: they are listed
    kept = set(kept_keys(listed))  # deterministic without noise: the first seed only
    unique = {k: j for k, j in unique.items() if k in kept}
    jobs = list(unique.values())
    check_results_dir(out, fields, recovery, backend)
    drop_partial_row(out / "results.csv")
    done = {row_key(r) for r in read_results(out)}
    keys = [j.key for j in jobs]
    check_same_run(out, listed, config, settings)
    if needs_scores(out, fields):  # a directory from before the score: its rows scored first
        worlds = {j.world.name: j.world for j in jobs}
        add_scores(
            out, fields, {n: reference_length(w) for n, w in worlds.items()}, v_max,
            {n: official_length(w) for n, w in worlds.items()},
        )  # fmt: skip
    todo = [j for j in jobs if j.key not in done]
    settings[DIGESTS_KEY] = world_digests(j.world for j in unique.values())
    plan = plan_reuse(reuse, todo, config, settings, fields) if reuse else None
    if record := reused_record(out, plan):  # kept over a plain resume
        settings[REUSED_KEY] = record
    taken = plan.taken if plan else set()
    todo = [j for j in todo if j.key not in taken]
    with open_backend(workers, ray_address, needed=bool(todo or plan and plan.checks)) as run:
        if plan:  # nothing is written to out before the check episodes agree with DIR
            plan.rerun(run, _worker, config, v_max, progress)
        (out / "logs").mkdir(parents=True, exist_ok=True)
        write_meta(out, config, settings, fields, keys)
        if todo or taken:
            for name in DERIVED_PAGES:
                (out / name).unlink(missing_ok=True)
        with (
            appending_rows(out, fields) as append,
            # a resumed run's bar starts at the episodes already in results.csv
            tqdm(
                total=len(jobs),
                initial=len(jobs) - len(todo),
                disable=not progress,
                desc="episodes",
                unit="ep",
            ) as bar,
        ):
            if plan:
                plan.copy(out, append, v_max)
            for job, result in run(_worker, todo, config):
                save_log(result, out / "logs" / job.log_name)
                append(job.row(result, v_max))
                bar.set_postfix_str(f"{job.world.name} {job.method}: {result.outcome}")
                bar.update(1)
    rows = [r for r in read_results(out) if row_key(r) in unique]
    if {row_key(r) for r in rows} == unique.keys():  # complete: order no longer run-dependent
        order_results(out, keys)
        rank = {k: i for i, k in enumerate(keys)}
        rows.sort(key=lambda r: rank[row_key(r)])
    return rows


def key_apart(worlds: Sequence[World]) -> tuple[list[World], dict[str, str]]:
    """Worlds whose results keys are distinct, and what each renamed key stands for.

    Results, logs and figures name a world by its ``name:``. Where two different worlds of
    one command share a name (two files, or a custom world named ``TS1`` beside the shipped
    one), the first listed keeps it and every other becomes ``<name>@<digest>``, the first 8
    hex digits of the SHA-256 of its content; returns the worlds and {key: source} of the
    renamed ones, which the table prints. The same world listed twice stays one world."""
    first: dict[str, World] = {}
    out, renamed = [], {}
    for world in worlds:
        seen = first.setdefault(world.name, world)
        if seen is world or replace(seen, source="") == replace(world, source=""):
            out.append(world)
            continue
        content = repr(replace(world, source="")).encode()
        key = f"{world.name}@{hashlib.sha256(content).hexdigest()[:8]}"
        renamed[key] = world.source
        out.append(replace(world, name=key))
    return out, renamed


def check_distinct(jobs: Sequence[Job]) -> None:
    """ConfigError when two different worlds of one run share a name, or two episodes
    would share a log file (names that differ only in characters a file name cannot hold).

    A results row, its log and its figures name a world by its ``name:`` only, so two world
    files with one name (or a custom world named ``TS1`` beside the shipped one) would mix
    their rows under one key: the run is refused, naming both files, rather than keyed apart.
    The same world listed twice, or two files with the same content, is one world."""
    worlds: dict[str, World] = {}
    logs: dict[str, Key] = {}
    for job in jobs:
        first = worlds.setdefault(job.world.name, job.world)
        if first is not job.world and replace(first, source="") != replace(job.world, source=""):
            raise ConfigError(
                f"worlds {first.source} and {job.world.source} are both named "
                f"{job.world.name!r}; results are keyed by world name, so their rows would "
                "mix: give one of them another name: field"
            )
        other = logs.setdefault(job.log_name, job.key)
        if other != job.key:
            raise ConfigError(
                f"episodes {other} and {job.key} would share the log file "
                f"logs/{job.log_name}; rename a world so the names differ in a letter or digit"
            )


def world_figures(
    out: Path,
    worlds: Iterable[World],
    methods: Sequence[str],
    seed: int,
    noise: str,
    policy_seeds: Mapping[str, int | None] | None = None,
    progress: bool = False,
) -> list[Path]:
    """One figure per world: every method's trajectory, coloured by time (and by tau for
    learned). policy_seeds: the training seed whose episode is drawn, per method (default
    none: a fixed method or a single policy). Each figure says which episode a panel is (the
    evaluation seed in its title, a learned method's training seed in its panel's), since the
    tables average over every seed. progress: a bar on stderr, one step per world."""
    # matplotlib takes ~0.3 s to import; every spawned worker imports this module, none draws
    from d3dwa_bullet.evaluation.plotting import trajectory_figure
    from d3dwa_bullet.planning.global_plan import logged_paths

    policy_seeds = policy_seeds or {}
    paths = []
    worlds = list(worlds)
    shown = f"one episode each: evaluation seed {seed}, noise {noise}"
    for world in tqdm(worlds, desc="figures", unit="world", disable=not progress, leave=False):
        runs = []
        for method in methods:
            job = Job(world, method, seed, noise, policy_seed=policy_seeds.get(method))
            log_path = out / "logs" / job.log_name
            if not log_path.exists():
                continue
            log = load_log(log_path)
            runs.append(
                {
                    # the name the results and P(A > B) tables use: twelve labels fit a grid
                    "label": method
                    + ("" if job.policy_seed is None else f" · seed {job.policy_seed}"),
                    "method": method,
                    "outcome": str(log["outcome"]),
                    "t": np.append(log["t"], log["t"][-1] + 0.1) if len(log["t"]) else np.zeros(1),
                    "x": log["true_x"],
                    "y": log["true_y"],
                    "plan": logged_paths(log),
                    "tau": np.append(log["tau"], log["tau"][-1])
                    if len(log["tau"])
                    else np.zeros(1),
                }
            )
        if not runs:
            continue
        fig_dir = out / "figures"
        trained = (
            "; · seed k: training seed k"
            if any(p is not None for p in policy_seeds.values())
            else ""
        )
        title = f"{world.name}: {world.description} ({shown}{trained})"
        paths.append(
            trajectory_figure(world, runs, fig_dir / figure_name(world.name, "time"), title=title)
        )
        learned = [r for r in runs if r["method"].startswith("d3dwa")]
        if learned:
            paths.append(
                trajectory_figure(
                    world,
                    learned,
                    fig_dir / figure_name(world.name, "tau"),
                    colour_by="tau",
                    title=f"{world.name}: D3DWA trajectories coloured by the selected horizon "
                    f"({shown}{trained})",
                )  # fmt: skip
            )
    return paths
