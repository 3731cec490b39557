"""The directory of one training run: where each file lives, and the checks before writing.

Layout::

    <out>/config.json          the TrainConfig (reload it with load_train_config)
    <out>/run.json             run name, package version, start time (and a warm start's
                               source folder and weights hash)
    <out>/episodes.csv         one row per training episode
    <out>/metrics.jsonl        TensorBoard-style records {"step", "tag", "value"} (charts/...,
                               losses/..., eval/..., curriculum/...) and the per-episode
                               horizon histogram {"step", "tag": "planner/tau", "histogram"}
    <out>/tb/                  the same records as TensorBoard event files (logs.py)
    <out>/learning_curve.png   return and success rate vs environment steps
    <out>/summary.json         status, counters, wall time, throughput, evaluations
    <out>/checkpoints/latest/  resumable: policy + config.json + training state
    <out>/checkpoints/best/    policy with the best greedy evaluation (on eval_worlds)
    <out>/checkpoints/final/   policy at the end of the budget
    <out>/policy/              the policy to ship (``keep``: best or final) + config.json
                               + learning_curve.png, no replay buffer

A new run refuses a directory that already holds one; a resumed run needs its own
``config.json`` and a config that differs from the saved one only in ``total_steps``, and
goes on from ``checkpoints/latest`` (a run that stopped before its first checkpoint starts
again from step 0).
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.learning.agents.checkpoint import CONFIG_FILE, META_FILE, SUMMARY_FILE
from d3dwa_bullet.learning.training.config import (
    TrainConfig,
    check_selection_rule,
    load_train_config,
)

RUN_FILE = "run.json"
EPISODES_FILE = "episodes.csv"
METRICS_FILE = "metrics.jsonl"
TENSORBOARD_DIR = "tb"
CHECKPOINTS_DIR = "checkpoints"
POLICY_DIR = "policy"
#: The append-only logs (truncated to a checkpoint's sizes on resume).
LOG_FILES = (EPISODES_FILE, METRICS_FILE)


def checkpoint_dir(out: Path, name: str) -> Path:
    """``<out>/checkpoints/<name>`` (latest, best or final)."""
    return out / CHECKPOINTS_DIR / name


def check_new_run(out: Path, config: TrainConfig | None) -> TrainConfig:
    """``config`` for a new run in ``out``; ConfigError if there is none or ``out`` already
    holds a training run."""
    if config is None:
        raise ConfigError("train: a TrainConfig is needed unless resuming")
    if out.exists() and any((out / n).exists() for n in (CONFIG_FILE, CHECKPOINTS_DIR, *LOG_FILES)):
        raise ConfigError(
            f"{out}: already holds a training run; pass --resume to continue it "
            "or choose a new --out directory"
        )
    check_selection_rule(config)
    return config


def resume_config(out: Path, config: TrainConfig | None) -> TrainConfig:
    """The config a resumed run in ``out`` goes on with: its own ``config.json`` when
    ``config`` is None, else ``config`` if it differs from that only in total_steps.
    ConfigError if there is nothing to resume or the config differs in anything else."""
    path = out / CONFIG_FILE
    if not path.exists():
        raise ConfigError(f"{path}: missing; nothing to resume in {out}")
    saved = load_train_config(path)
    if config is None:
        config = saved
    else:
        a, b = config.to_dict(), saved.to_dict()
        a.pop("total_steps"), b.pop("total_steps")
        diff = sorted(k for k in a if a[k] != b[k])
        if diff:
            raise ConfigError(
                f"{out / CONFIG_FILE}: resuming with a config that differs in "
                f"{diff}; only total_steps may change on resume"
            )
    return config


def has_checkpoint(out: Path) -> bool:
    """Whether the run in ``out`` has saved its ``latest`` checkpoint."""
    return (checkpoint_dir(out, "latest") / META_FILE).exists()


def clear_before_first_checkpoint(out: Path) -> None:
    """Empty the logs and events of a run that stopped before its first checkpoint, so
    that it starts again from step 0: what a resume truncates a run to, for a run with no
    checkpoint (its config stays; the rest is rewritten)."""
    for name in LOG_FILES:
        (out / name).unlink(missing_ok=True)
    shutil.rmtree(out / TENSORBOARD_DIR, ignore_errors=True)


def config_bytes(config: TrainConfig) -> bytes:
    """The ``config.json`` content of a config (also saved beside every checkpoint)."""
    return (json.dumps(config.to_dict(), indent=2) + "\n").encode()


def write_config(out: Path, config: TrainConfig) -> None:
    """Write ``<out>/config.json`` (on resume: the possibly extended total_steps)."""
    (out / CONFIG_FILE).write_text(config_bytes(config).decode())


def write_run_info(out: Path, config: TrainConfig, extra: Mapping[str, Any] | None = None) -> None:
    """Write ``<out>/run.json``: run name ``D3DWA-v0__<method>__<seed>__<time>``, package
    version and start time, and ``extra`` (the network a warm start loaded)."""
    run = {
        "name": f"D3DWA-v0__{config.method}__{config.seed}__{int(time.time())}",
        "package_version": __version__,
        "started": datetime.now(UTC).isoformat(timespec="seconds"),
        **(extra or {}),
    }
    (out / RUN_FILE).write_text(json.dumps(run, indent=2) + "\n")


def write_summary(out: Path, summary: dict[str, Any]) -> None:
    """Write ``<out>/summary.json``, swapped in whole."""
    atomic_write_text(out / SUMMARY_FILE, json.dumps(summary, indent=2) + "\n")
