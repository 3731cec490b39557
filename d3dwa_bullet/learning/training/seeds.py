"""Training one config over several seeds: ``<out>/seed-<k>/`` per seed, resumable per seed.

A method's result is its distribution over training seeds (docs/design/learning-protocol.md#learning-protocol),
so ``d3dwa train --config C --seeds 0-4 --out runs/NAME`` trains every seed of one committed
config into its own run directory, one after the other (each run already uses every core).
With ``--resume`` a seed whose run is complete is skipped, one with a checkpoint continues
and one never started starts. A seed that fails is reported and the others still run; the
failed ones resume later. ``--export DIR`` ships every finished seed as ``DIR/seed-<k>/``.

Ctrl-C stops the whole command at the next safe point: the seed training stops at its next
step boundary (or after its final evaluation) and saves ``latest``, the seeds after it never
start (status "stopped"), every finished seed is kept, and ``--resume`` goes on from there.
``<out>`` is locked while the command runs and each ``seed-<k>/`` while its seed trains
(:mod:`d3dwa_bullet.dir_lock`): a second command into either is refused, not interleaved.

With ``--ray ADDRESS`` (the forms ``d3dwa eval`` accepts) each seed is a Ray task asking
for ``n_envs`` CPUs, its env workers inside it, writing the same run directory as a local
run (the run directories must be on a filesystem every node sees). A task that dies is
that seed's failure; the other seeds are kept.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import d3dwa_bullet.learning.training.warm_start as warm_start
from d3dwa_bullet.backends import check_address, ray_session
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.errors import BusyError, ConfigError, D3DWAError, TrainingError
from d3dwa_bullet.learning.training.checkpoints import check_export_target, export_policy
from d3dwa_bullet.learning.training.config import TrainConfig, check_selection_rule
from d3dwa_bullet.learning.training.interrupt import StopOnInterrupt
from d3dwa_bullet.learning.training.run_dir import SUMMARY_FILE
from d3dwa_bullet.learning.training.trainer import train
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.seed_dirs import seed_dir


@dataclass
class SeedOutcome:
    """What happened to one seed: its run directory, status, summary or error."""

    seed: int
    out: Path
    status: str
    """'done', 'skipped' (already complete), 'interrupted', 'failed' or 'stopped' (not
    started: the command was interrupted before this seed)."""
    summary: dict[str, Any] | None = None
    error: str | None = None
    exported: Path | None = None


def _complete(out: Path, total_steps: int) -> bool:
    path = out / SUMMARY_FILE
    if not path.is_file():
        return False
    summary = load_json(path, TrainingError, "run summary")
    return summary.get("status") == "done" and int(summary.get("env_steps", -1)) >= total_steps


def train_seeds(
    config: TrainConfig,
    out: str | Path,
    seeds: Sequence[int],
    resume: bool = False,
    export: str | Path | None = None,
    progress: bool = True,
    on_seed: Callable[[SeedOutcome], None] | None = None,
    ray_address: str | None = None,
) -> list[SeedOutcome]:
    """Train ``config`` once per seed into ``out/seed-<k>/`` (module docstring).

    Without ``resume``, ConfigError if any seed's directory already holds a run (before
    anything trains); with ``export``, ConfigError if any ``export/seed-<k>/`` holds
    another run's policy (``check_export_target``, before anything trains). BusyError if another process writes ``out`` or a seed's directory.
    Ctrl-C (SIGINT) stops after the current seed's checkpoint (module docstring).
    """
    out = Path(out)
    if not seeds:
        raise ConfigError("--seeds: no seed given")
    check_selection_rule(config)
    for seed in () if resume else seeds:  # every seed's warm start fits before any trains
        warm_start.source(replace(config, seed=seed))
    check_address(ray_address)
    if export is not None:  # a policy another run exported is never replaced
        for seed in seeds:
            check_export_target(seed_dir(out, seed), seed_dir(export, seed))
    with locked_dir(out):
        for seed in seeds:  # a seed another command trains is refused before any seed trains
            with locked_dir(seed_dir(out, seed)):  # (each seed's training locks it again)
                pass
        return _train_seeds(config, out, seeds, resume, export, progress, on_seed, ray_address)


def _train_seeds(
    config: TrainConfig,
    out: Path,
    seeds: Sequence[int],
    resume: bool,
    export: str | Path | None,
    progress: bool,
    on_seed: Callable[[SeedOutcome], None] | None,
    ray_address: str | None,
) -> list[SeedOutcome]:
    if not resume:
        taken = [
            str(seed_dir(out, s)) for s in seeds if (seed_dir(out, s) / "config.json").exists()
        ]
        if taken:
            raise ConfigError(
                f"{taken[0]} already holds a training run; continue with --resume or choose "
                "another --out"
            )
    todo = []
    outcomes: list[SeedOutcome] = []
    for seed in seeds:
        run = seed_dir(out, seed)
        if resume and _complete(run, config.total_steps):
            outcomes.append(_finish(SeedOutcome(seed, run, "skipped"), config, export, on_seed))
        else:
            todo.append((seed, run, resume and (run / "config.json").exists()))
    order = {seed: i for i, seed in enumerate(seeds)}
    if ray_address is not None:
        outcomes += _train_on_ray(config, todo, ray_address, export, on_seed)
        return sorted(outcomes, key=lambda o: order[o.seed])
    with StopOnInterrupt() as stop:  # each seed's training holds its own inside this one
        for seed, run, again in todo:
            if stop.requested:  # Ctrl-C: no further seed starts
                outcome = SeedOutcome(seed, run, "stopped")
            else:
                try:
                    summary = train(replace(config, seed=seed), run, resume=again,
                                    progress=progress)  # fmt: skip
                except BusyError:  # another command trains this seed: not this seed's failure
                    raise
                except D3DWAError as err:
                    outcome = SeedOutcome(seed, run, "failed", error=str(err))
                else:
                    outcome = SeedOutcome(seed, run, summary["status"], summary=summary)
                    if outcome.status == "interrupted":
                        stop.requested = True
            outcomes.append(_finish(outcome, config, export, on_seed))
    return sorted(outcomes, key=lambda o: order[o.seed])


def _finish(
    outcome: SeedOutcome,
    config: TrainConfig,
    export: str | Path | None,
    on_seed: Callable[[SeedOutcome], None] | None,
) -> SeedOutcome:
    """Export a finished seed (policy + config + curve + summary) and report it."""
    if export is not None and outcome.status in ("done", "skipped"):
        # the run's summary travels with the policy, in the same atomic write (a resumed
        # --seeds run exports a finished seed again over its own export)
        outcome.exported = export_policy(
            outcome.out, seed_dir(Path(export), outcome.seed), config.keep
        )
    if on_seed is not None:
        on_seed(outcome)
    return outcome


def _seed_task(config: TrainConfig, run: str, resume: bool) -> dict[str, Any]:
    """One seed's training as a Ray task (no progress bar: nobody watches a task's stderr)."""
    return train(config, Path(run), resume=resume, progress=False)


def _train_on_ray(
    config: TrainConfig,
    todo: list[tuple[int, Path, bool]],
    address: str,
    export: str | Path | None,
    on_seed: Callable[[SeedOutcome], None] | None,
) -> list[SeedOutcome]:
    outcomes: list[SeedOutcome] = []
    with ray_session(address, workers=config.n_envs) as ray:
        task = ray.remote(num_cpus=config.n_envs)(_seed_task)
        pending = {
            task.remote(replace(config, seed=seed), str(run), again): (seed, run)
            for seed, run, again in todo
        }
        try:
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                seed, run = pending.pop(done[0])
                try:
                    summary = ray.get(done[0])
                except (ray.exceptions.RayTaskError, ray.exceptions.RayError) as err:
                    cause = getattr(err, "cause", None)
                    message = str(cause) if isinstance(cause, D3DWAError) else _first_line(err)
                    outcome = SeedOutcome(seed, run, "failed", error=message)
                else:
                    outcome = SeedOutcome(seed, run, summary["status"], summary=summary)
                outcomes.append(_finish(outcome, config, export, on_seed))
        finally:
            for ref in pending:  # interrupted: cancel the seeds not finished
                ray.cancel(ref, force=True)
    return outcomes


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return f"the Ray task died: {text.splitlines()[0] if text else type(err).__name__}"
