"""Evaluate methods on worlds over seeds: independent episodes, spread over processes.

A results directory holds::

    meta.json          format version, package version, episode config, the command's
                       settings and the key of every job of the last run (what "complete" means)
    results.csv        one row per finished episode, appended as episodes finish
    logs/*.npz         the per-step log of every episode (pose, command, weights, tau, obs)
    table.md           Table I layout, written only once every episode is in results.csv
    figures/*.png      one trajectory figure per world (all methods side by side)

Rows are appended and flushed one by one, so an interrupted run loses nothing finished;
running the same command again skips episodes already in results.csv (a row cut short by
a kill is dropped and its episode rerun). Pages derived from the rows (table.md, sweep.md,
report.md) are deleted when a run starts with episodes to do and rewritten once it is
complete, so a stale page never poses as the result of the current job set.

Episodes run in this process, in a pool of spawned processes (``workers``) or on a Ray
cluster (``ray_address``, see :mod:`d3dwa_bullet.backends`), with identical rows.
"""

from __future__ import annotations

import csv
import json
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from d3dwa_bullet import __version__
from d3dwa_bullet.episode import EpisodeConfig, EpisodeResult, run_episode
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.backends import open_backend
from d3dwa_bullet.methods import LABELS, make_controller
from d3dwa_bullet.sim.noise import NoiseConfig, NoiseModel
from d3dwa_bullet.world.model import World

RESULTS_FORMAT = 2
"""2: meta.json lists the run's job keys and settings (1 had neither)."""
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
DERIVED_PAGES = ("table.md", "sweep.md", "report.md")
"""Pages computed from results.csv; removed while a run is incomplete."""
_UNSAFE = re.compile(r"[^A-Za-z0-9._=+-]")


@dataclass(frozen=True)
class Job:
    """One episode to run."""

    world: World
    method: str
    seed: int
    noise: str = "none"
    """A profile name (none, paper, real, harsh, a YAML path), or the label of noise_config."""
    policy: str | None = None
    noise_config: str | None = None
    """JSON of ``NoiseConfig.to_dict()``: this exact noise instead of sampling a profile
    (the episode then gets ``NoiseModel(config, seed)``). A string keeps Job hashable."""
    columns: tuple[tuple[str, str | float | int], ...] = ()
    """Extra CSV columns of this job's row, e.g. (("axis", "slip"), ("level", 0.1))."""

    @property
    def key(self) -> tuple[str, str, int, str]:
        return (self.world.name, self.method, self.seed, self.noise)

    @property
    def log_name(self) -> str:
        name = f"{self.world.name}__{self.method}__{self.noise}__s{self.seed}"
        return _UNSAFE.sub("_", name) + ".npz"

    def row(self, result: EpisodeResult) -> dict[str, Any]:
        """The CSV row of this job's result."""
        return result.summary() | dict(self.columns)


def make_noise(profile: str, seed: int):
    """The NoiseModel of an episode under a named profile (None for 'none')."""
    if profile == "none":
        return None
    from randomization import episode_noise, load_profile

    return episode_noise(load_profile(profile), seed)


def noise_config_json(config: NoiseConfig) -> str:
    """The Job.noise_config string of a NoiseConfig (canonical: sorted keys)."""
    return json.dumps(config.to_dict(), sort_keys=True)


def job_noise(job: Job) -> NoiseModel | None:
    """The NoiseModel of a job: its explicit config, else its profile, else None."""
    if job.noise_config is not None:
        return NoiseModel(NoiseConfig.from_dict(json.loads(job.noise_config)), job.seed)
    return make_noise(job.noise, job.seed)


def run_job(job: Job, config: EpisodeConfig = EpisodeConfig()) -> EpisodeResult:
    """Run one job in this process."""
    controller = make_controller(job.method, job.policy)
    return run_episode(
        job.world, controller, seed=job.seed, noise=job_noise(job),
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


def read_meta(out: Path) -> dict[str, Any]:
    """meta.json of a results directory ({} if absent)."""
    meta = out / "meta.json"
    if not meta.exists():
        return {}
    try:
        data = json.loads(meta.read_text())
    except json.JSONDecodeError as err:
        raise ResultsError(f"{meta}: not valid JSON ({err})") from err
    if not isinstance(data, dict):
        raise ResultsError(f"{meta}: expected a JSON object, got {type(data).__name__}")
    return data


def csv_header(out: Path) -> list[str] | None:
    """The column names of out/results.csv (None if absent or empty)."""
    path = out / "results.csv"
    if not path.exists():
        return None
    with path.open(newline="") as fh:
        return next(csv.reader(fh), None)


def check_results_dir(out: Path, fields: Sequence[str] | None = None) -> None:
    """Refuse a results directory written by another format version, or (with fields) one
    whose results.csv has other columns (e.g. a sweep's directory given to eval)."""
    meta = out / "meta.json"
    if meta.exists():
        fmt = read_meta(out).get("format")
        if fmt != RESULTS_FORMAT:
            raise ResultsError(
                f"{meta}: results format {fmt!r}, this version writes {RESULTS_FORMAT}; use a new --out directory"
            )
    elif (out / "results.csv").exists():
        raise ResultsError(
            f"{out}: results.csv without meta.json (older version?); use a new --out directory"
        )
    header = csv_header(out)
    if fields is not None and header is not None and header != list(fields):
        kind = read_meta(out).get("settings", {}).get("kind", "another command")
        raise ResultsError(
            f"{out / 'results.csv'}: columns {header} were written by {kind!r}, this command "
            f"writes {list(fields)}; use another --out directory"
        )


def drop_partial_row(path: Path) -> bool:
    """Cut a last line without its newline (a row half-written when the run was killed);
    True if something was cut. Its episode is then simply run again."""
    if not path.exists() or path.stat().st_size == 0:
        return False
    with path.open("rb+") as fh:
        fh.seek(-1, os.SEEK_END)
        if fh.read(1) == b"\n":
            return False
        fh.seek(0)
        data = fh.read()
        fh.seek(data.rfind(b"\n") + 1)
        fh.truncate()
    return True


def write_text_atomic(path: Path, text: str) -> None:
    """Write text to path via a temporary file and a rename: never a half-written file."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def completion(out: Path, rows: Sequence[dict[str, Any]] | None = None) -> tuple[int, int]:
    """(episodes finished, episodes in the last run's job list) of a results directory."""
    jobs = {tuple(k) for k in read_meta(out).get("jobs", [])}
    rows = read_results(out) if rows is None else rows
    done = {(r["world"], r["method"], r["seed"], r["noise"]) for r in rows}
    return len(jobs & done), len(jobs)


def evaluate(
    jobs: Sequence[Job],
    out: str | os.PathLike[str],
    workers: int = 1,
    config: EpisodeConfig = EpisodeConfig(),
    progress: bool = True,
    ray_address: str | None = None,
    fields: Sequence[str] = CSV_FIELDS,
    settings: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Run every job not already in out/results.csv; returns all rows for these jobs.

    workers: local processes (1 = this process). ray_address: run on Ray instead (see
    :mod:`d3dwa_bullet.backends`). fields: the CSV columns (CSV_FIELDS plus the jobs'
    extra columns). settings: what the command was (kind, methods, worlds, ...), kept in
    meta.json for ``d3dwa report``.
    """
    out = Path(out)
    check_results_dir(out, fields)
    csv_path = out / "results.csv"
    drop_partial_row(csv_path)
    done = {(r["world"], r["method"], r["seed"], r["noise"]) for r in read_results(out)}
    unique: dict[tuple, Job] = {}
    for j in jobs:  # a world or seed named twice is one episode, not two rows
        unique.setdefault(j.key, j)
    jobs = list(unique.values())
    todo = [j for j in jobs if j.key not in done]
    with open_backend(workers, ray_address, needed=bool(todo)) as run:
        (out / "logs").mkdir(parents=True, exist_ok=True)
        meta = {
            "format": RESULTS_FORMAT,
            "version": __version__,
            "config": asdict(config),
            "settings": settings or {"kind": "eval"},
            "columns": list(fields),
            "jobs": [list(j.key) for j in jobs],
        }
        write_text_atomic(out / "meta.json", json.dumps(meta, indent=1, default=str))
        if todo:
            for name in DERIVED_PAGES:
                (out / name).unlink(missing_ok=True)
        new_file = not csv_path.exists() or csv_path.stat().st_size == 0
        with (
            csv_path.open("a", newline="") as fh,
            tqdm(total=len(todo), disable=not progress, desc="episodes", unit="ep") as bar,
        ):
            writer = csv.DictWriter(fh, fieldnames=list(fields), extrasaction="ignore")
            if new_file:
                writer.writeheader()
                fh.flush()
            for job, result in run(_worker, todo, config):
                save_log(result, out / "logs" / job.log_name)
                writer.writerow(job.row(result))
                fh.flush()
                bar.set_postfix_str(f"{job.world.name} {job.method}: {result.outcome}")
                bar.update(1)
    keys = {j.key for j in jobs}
    return [
        r for r in read_results(out) if (r["world"], r["method"], r["seed"], r["noise"]) in keys
    ]


def world_figures(
    out: Path, worlds: Iterable[World], methods: Sequence[str], seed: int, noise: str
) -> list[Path]:
    """One figure per world: every method's trajectory, coloured by time (and by tau for learned)."""
    from d3dwa_bullet.evaluation.plotting import trajectory_figure

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
