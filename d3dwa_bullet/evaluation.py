"""Evaluate methods on worlds over seeds: independent episodes, spread over processes.

A results directory holds::

    meta.json          format version, package version, the job list's settings
    results.csv        one row per finished episode, appended as episodes finish
    logs/*.npz         the per-step log of every episode (pose, command, weights, tau, obs)
    table.md           Table I layout, written only once every episode is in results.csv
    figures/*.png      one trajectory figure per world (all methods side by side)

Rows are appended and flushed one by one, so an interrupted run loses nothing finished;
running the same command again skips episodes already in results.csv.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from . import __version__
from .episode import EpisodeConfig, EpisodeResult, run_episode
from .errors import ResultsError
from .methods import LABELS, make_controller
from .world import World

RESULTS_FORMAT = 1
CSV_FIELDS = (
    "world",
    "method",
    "seed",
    "noise",
    "outcome",
    "time_s",
    "tl_m",
    "pd_rad",
    "min_clearance_m",
    "steps",
)


@dataclass(frozen=True)
class Job:
    """One episode to run."""

    world: World
    method: str
    seed: int
    noise: str = "none"
    policy: str | None = None

    @property
    def key(self) -> tuple[str, str, int, str]:
        return (self.world.name, self.method, self.seed, self.noise)

    @property
    def log_name(self) -> str:
        return f"{self.world.name}__{self.method}__{self.noise}__s{self.seed}.npz"


def make_noise(profile: str, seed: int):
    """The NoiseModel of an episode under a named profile (None for 'none')."""
    if profile == "none":
        return None
    from randomization import episode_noise, load_profile

    return episode_noise(load_profile(profile), seed)


def run_job(job: Job, config: EpisodeConfig = EpisodeConfig()) -> EpisodeResult:
    """Run one job in this process."""
    controller = make_controller(job.method, job.policy)
    return run_episode(
        job.world, controller, seed=job.seed, noise=make_noise(job.noise, job.seed),
        noise_name=job.noise, config=config,
    )  # fmt: skip


def save_log(result: EpisodeResult, path: Path) -> None:
    """Per-step log as .npz (atomic)."""
    tmp = path.with_name(path.stem + ".tmp.npz")
    np.savez_compressed(tmp, outcome=result.outcome, observations=result.observations, **result.log)
    os.replace(tmp, path)


def load_log(path: Path) -> dict[str, Any]:
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def _worker(job: Job, config: EpisodeConfig) -> tuple[Job, EpisodeResult]:
    return job, run_job(job, config)


def read_results(out: Path) -> list[dict[str, Any]]:
    """Rows of results.csv with typed values (empty if absent)."""
    path = out / "results.csv"
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        if set(CSV_FIELDS) - set(row):
            raise ResultsError(f"{path}: missing columns {sorted(set(CSV_FIELDS) - set(row))}")
        row["seed"], row["steps"] = int(row["seed"]), int(row["steps"])
        for k in ("time_s", "tl_m", "pd_rad", "min_clearance_m"):
            row[k] = float(row[k])
    return rows


def check_results_dir(out: Path) -> None:
    """Refuse a results directory written by another format version."""
    meta = out / "meta.json"
    if meta.exists():
        try:
            fmt = json.loads(meta.read_text()).get("format")
        except json.JSONDecodeError as err:
            raise ResultsError(f"{meta}: not valid JSON ({err})") from err
        if fmt != RESULTS_FORMAT:
            raise ResultsError(
                f"{meta}: results format {fmt!r}, this version writes {RESULTS_FORMAT}; use a new --out directory"
            )
    elif (out / "results.csv").exists():
        raise ResultsError(
            f"{out}: results.csv without meta.json (older version?); use a new --out directory"
        )


def evaluate(
    jobs: Sequence[Job],
    out: str | os.PathLike[str],
    workers: int = 1,
    config: EpisodeConfig = EpisodeConfig(),
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Run every job not already in out/results.csv; returns all rows for these jobs."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "logs").mkdir(exist_ok=True)
    check_results_dir(out)
    (out / "meta.json").write_text(
        json.dumps(
            {"format": RESULTS_FORMAT, "version": __version__, "config": asdict(config)},
            indent=2,
            default=str,
        )
    )
    done = {(r["world"], r["method"], r["seed"], r["noise"]) for r in read_results(out)}
    todo = [j for j in jobs if j.key not in done]
    csv_path = out / "results.csv"
    new_file = not csv_path.exists()
    with (
        csv_path.open("a", newline="") as fh,
        tqdm(total=len(todo), disable=not progress, desc="episodes", unit="ep") as bar,
    ):
        writer = csv.DictWriter(fh, fieldnames=CSV_FIELDS, extrasaction="ignore")
        if new_file:
            writer.writeheader()
            fh.flush()

        def record(job: Job, result: EpisodeResult) -> None:
            save_log(result, out / "logs" / job.log_name)
            writer.writerow(result.summary())
            fh.flush()
            bar.set_postfix_str(f"{job.world.name} {job.method}: {result.outcome}")
            bar.update(1)

        if workers <= 1 or len(todo) <= 1:
            for job in todo:
                record(*_worker(job, config))
        else:
            with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
                pending = {pool.submit(_worker, job, config) for job in todo}
                while pending:
                    finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in finished:
                        record(*fut.result())
    keys = {j.key for j in jobs}
    return [
        r for r in read_results(out) if (r["world"], r["method"], r["seed"], r["noise"]) in keys
    ]


def world_figures(
    out: Path, worlds: Iterable[World], methods: Sequence[str], seed: int, noise: str
) -> list[Path]:
    """One figure per world: every method's trajectory, coloured by time (and by tau for learned)."""
    from .plotting import trajectory_figure

    paths = []
    for world in worlds:
        runs = []
        for method in methods:
            log_path = out / "logs" / Job(world, method, seed, noise).log_name
            if not log_path.exists():
                continue
            log = load_log(log_path)
            runs.append(
                {
                    "label": LABELS.get(method, method),
                    "method": method,
                    "outcome": str(log["outcome"]),
                    "t": np.append(log["t"], log["t"][-1] + 0.1) if len(log["t"]) else np.zeros(1),
                    "x": log["true_x"],
                    "y": log["true_y"],
                    "tau": np.append(log["tau"], log["tau"][-1])
                    if len(log["tau"])
                    else np.zeros(1),
                }
            )
        if not runs:
            continue
        fig_dir = out / "figures"
        paths.append(trajectory_figure(world, runs, fig_dir / f"{world.name}_time.png"))
        learned = [r for r in runs if r["method"].startswith("d3dwa")]
        if learned:
            paths.append(
                trajectory_figure(
                    world,
                    learned,
                    fig_dir / f"{world.name}_tau.png",
                    colour_by="tau",
                    title=f"{world.name}: D3DWA trajectories coloured by the selected horizon",
                )  # fmt: skip
            )
    return paths
