"""The checkpoints a training run writes, and the policy it exports.

``checkpoints/latest`` is resumable (policy, config.json, learning curve and the training
state); ``checkpoints/best`` and ``checkpoints/final`` are policies with config.json;
``export_policy`` copies one of them, without any training state, to where a policy is
shipped (``policies/<method>/``). Every checkpoint is swapped in atomically by
``save_checkpoint``, and non-finite values are never saved (``check_finite``): the last
good checkpoint stays.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError, TrainingError
from d3dwa_bullet.learning.agents.barn_record import barn_record
from d3dwa_bullet.learning.agents.checkpoint import (
    CONFIG_FILE,
    CURVE_FILE,
    SUMMARY_FILE,
    Agent,
    load_checkpoint,
    save_checkpoint,
)
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.numpy_policy import write_beside_weights
from d3dwa_bullet.learning.agents.training_state import (
    restore_training_state,
    training_state_files,
)
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.learning.training.logs import MetricsLog, learning_curve
from d3dwa_bullet.learning.training.run_dir import checkpoint_dir, config_bytes
from d3dwa_bullet.learning.training.state import TrainingProgress
from d3dwa_bullet.loading import load_json


def check_finite(agent: Agent, out: Path, step: int) -> None:
    """TrainingError if the agent's weights (or Q-table) hold NaN or inf."""
    if isinstance(agent, D3QNAgent):
        ok = all(bool(v.isfinite().all()) for v in agent.online.state_dict().values())
    else:
        ok = bool(np.isfinite(agent.table).all())
    if not ok:
        raise TrainingError(
            f"{out}: the {agent.method_family} agent's values became NaN/inf at step "
            f"{step}; nothing saved (the last good checkpoint is kept)"
        )


def run_metadata(
    config: TrainConfig, out: Path, progress: TrainingProgress, extra: Mapping[str, Any] | None
) -> dict[str, Any]:
    """The ``metadata`` of a run's checkpoint: method, run, counters, training material."""
    c = config
    return {
        "method": c.method,
        "run": out.name,
        "env_steps": progress.env_steps,
        "episodes": progress.episodes,
        "worlds": list(c.worlds),
        "generators": list(c.generators),
        "noise": list(c.noise),
        "reward_scale": c.reward_scale,
        "observation": c.observation,
        "decision_steps": c.decision_steps,  # a policy holds each action this many steps
        "recovery": c.recovery,  # the layer it trained inside (run it with --recovery so)
        "scan_filter": c.scan_filter,  # the filter it trained behind (run it with --scan-filter so)
        **barn_metadata(c),
        **dict(extra or {}),
    }


def barn_metadata(config: TrainConfig) -> dict[str, Any]:
    """``{"barn": {"split": ..., "ids": [...]}}``: the BARN worlds a run trains on (their numbers,
    in ``barn_ids`` order), so that a policy trained on them can be told apart; {} when
    ``barn_split`` is 'none' (the meta of earlier policies is unchanged)."""
    return barn_record(config.barn_split, config.barn_ids)


def save_latest(
    out: Path, agent: Agent, config: TrainConfig, progress: TrainingProgress, logs: MetricsLog
) -> None:
    """Redraw the learning curve and save the resumable ``checkpoints/latest``."""
    check_finite(agent, out, progress.env_steps)
    learning_curve(out, out / CURVE_FILE,
                   f"{config.method}: {progress.env_steps} steps, seed {config.seed}",
                   step_seconds=0.1 * config.decision_steps)  # fmt: skip
    files: dict[str, Any] = dict(training_state_files(agent, progress.to_dict(logs.sizes())))
    files[CONFIG_FILE] = config_bytes(config)
    files[CURVE_FILE] = out / CURVE_FILE
    save_checkpoint(checkpoint_dir(out, "latest"), agent, run_metadata(config, out, progress, None),
                    method=config.method, extra_files=files)  # fmt: skip


def load_latest(out: Path, config: TrainConfig) -> tuple[Agent, dict[str, Any]]:
    """The agent of ``checkpoints/latest`` with its training state restored, and the
    trainer's state saved beside it (CheckpointError if anything does not fit)."""
    latest = checkpoint_dir(out, "latest")
    agent, _ = load_checkpoint(
        latest, expected_actions=config.actions, expected_layout=config.obs_layout
    )
    return agent, restore_training_state(latest, agent)


def save_policy(
    out: Path,
    name: str,
    agent: Agent,
    config: TrainConfig,
    progress: TrainingProgress,
    extra: Mapping[str, Any],
) -> Path:
    """Save the policy ``checkpoints/<name>`` (best or final) with the run's config.json."""
    check_finite(agent, out, progress.env_steps)
    return save_checkpoint(
        checkpoint_dir(out, name),
        agent,
        run_metadata(config, out, progress, extra),
        method=config.method,
        extra_files={CONFIG_FILE: config_bytes(config)},
    )


def export_policy(
    run_dir: str | os.PathLike[str], dest: str | os.PathLike[str], which: str = "best"
) -> Path:
    """Copy a run's policy (checkpoints/<which>) to ``dest`` with config.json, the learning
    curve and the run's summary, without any training state (what ``policies/<method>/`` holds),
    and a D3QN's weights.npz beside its weights.pt."""
    run = Path(run_dir)
    src = checkpoint_dir(run, which)
    agent, meta = load_checkpoint(src, expected_layout=None)  # copied as it is
    extra: dict[str, Any] = {CONFIG_FILE: run / CONFIG_FILE}
    if (run / CURVE_FILE).exists():
        extra[CURVE_FILE] = run / CURVE_FILE
    if (run / SUMMARY_FILE).exists():  # the run's counters, evaluations and wall time
        extra[SUMMARY_FILE] = run / SUMMARY_FILE
    path = save_checkpoint(dest, agent, meta["metadata"], method=meta["method"], extra_files=extra)
    if isinstance(agent, D3QNAgent):  # evaluation then runs it without torch (numpy_policy)
        write_beside_weights(
            path, {k: v.detach().cpu().numpy() for k, v in agent.state_dict().items()}
        )
    return path


def check_export_target(run_dir: str | os.PathLike[str], dest: str | os.PathLike[str]) -> None:
    """ConfigError (one line) unless ``dest`` may take ``run_dir``'s export: missing, empty, or
    an export of this very run (its summary.json names ``run_dir``: a resumed run exports a
    finished seed again over its own export). Called before training starts, so a policy
    another run exported (a shipped seed copied beside new ones, say) is never replaced."""
    target, run = Path(dest), Path(run_dir)
    if not target.exists() or (target.is_dir() and not any(target.iterdir())):
        return
    source = None
    if (target / SUMMARY_FILE).is_file():
        try:
            source = load_json(target / SUMMARY_FILE, TrainingError, "run summary").get("run_dir")
        except (TrainingError, AttributeError):
            source = None
    started = (run / CONFIG_FILE).is_file()  # a run not started yet exported nothing
    if started and isinstance(source, str) and Path(source).resolve() == run.resolve():
        return
    held = (
        f"another run's policy (trained in {source})" if isinstance(source, str) else "other files"
    )
    raise ConfigError(
        f"--export: {target} already holds {held}, not {run}'s; export elsewhere, or move that "
        "folder away first"
    )
