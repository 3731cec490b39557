"""The resumable state of a training run, and how a resumed run rebuilds it exactly.

Resumption is exact: ``checkpoints/latest`` holds the agent's training state (replay
buffer, Adam moments, target network, its RNGs and counters: ``agents.training_state``)
and the trainer's own ``TrainingProgress``: counters, timings, the schedule, the
curriculum, the rolling statistics, the evaluations, the sizes of the logs, and each env's
episode in progress as (its env RNG state before the draw, the curriculum's task weights at
its reset, the actions taken so far). A resumed run truncates the logs to the checkpoint
(``truncate_logs``), rebuilds every env's episode by replaying its actions
(``rebuild_plans``; the simulator is deterministic in DIRECT mode) and goes on as if never
stopped.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.utils.seeding import np_random

from d3dwa_bullet.errors import TrainingError
from d3dwa_bullet.io import AppendFile
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.learning.training.curriculum import Curriculum
from d3dwa_bullet.learning.training.logs import SUCCESS_WINDOW
from d3dwa_bullet.learning.training.run_dir import POLICY_DIR, checkpoint_dir
from d3dwa_bullet.learning.training.schedule import Schedule


@dataclass
class EpisodeProgress:
    """The episode in progress, as much as exact resumption needs."""

    reset_seed: int | None = None
    """Seed passed to reset() (first episode only, checkpoints of one-env runs), else None."""
    rng_before: dict[str, Any] | None = None
    """The env's RNG state just before this episode's draw (filled when a checkpoint is saved)."""
    task_weights: list[float] | None = None
    """The curriculum's task weights at this episode's reset (None: the env's base ones)."""
    actions: list[int] = field(default_factory=list)
    """Actions taken so far (replayed on resume; env.step draws nothing from the env RNG)."""
    ret: float = 0.0
    tau_counts: list[int] = field(default_factory=list)
    fallbacks: int = 0
    finished: bool = False
    """The episode has ended (the budget ran out at its last step)."""
    obs: list[float] = field(default_factory=list)
    """The current observation (checked after the replay on resume)."""


def _timing() -> dict[str, float]:
    return {"act": 0.0, "env": 0.0, "learn": 0.0, "eval": 0.0, "checkpoint": 0.0}


def _rng_state_of_seed(seed: int) -> dict[str, Any]:
    """The env RNG state right after ``reset(seed=seed)`` (Gymnasium's seeding)."""
    return np_random(int(seed))[0].bit_generator.state


@dataclass
class TrainingProgress:
    """Everything of the training loop that ``latest`` saves and a resumed run restores."""

    schedule: Schedule
    curriculum: Curriculum
    env_steps: int = 0
    episodes: int = 0
    wall_time: float = 0.0
    """Wall time of the run so far, s (summed over resumptions)."""
    cpu_time: float = 0.0
    """Process CPU time of the run, s (what the wall time would be on an idle core)."""
    timing: dict[str, float] = field(default_factory=_timing)
    """Wall time by part of the loop (act, env: waiting for the envs, learn, eval,
    checkpoint), s."""
    recent_returns: deque[float] = field(default_factory=lambda: deque(maxlen=SUCCESS_WINDOW))
    recent_success: deque[int] = field(default_factory=lambda: deque(maxlen=SUCCESS_WINDOW))
    loss_acc: dict[str, list[float]] = field(default_factory=dict)
    """Tag -> [sum, count] of the per-update losses since the last scalar log."""
    best: dict[str, Any] | None = None
    """The best greedy evaluation so far (the one saved as checkpoints/best)."""
    evals: list[dict[str, Any]] = field(default_factory=list)
    episodes_in_progress: list[EpisodeProgress] = field(default_factory=list)
    """Each env's current episode, in env order."""
    obs: np.ndarray = field(default_factory=lambda: np.zeros((1, 12), dtype=np.float32))
    """The current observation of each env, (n_envs, 12)."""

    @classmethod
    def start(cls, config: TrainConfig) -> TrainingProgress:
        """The progress of a new run of ``config``."""
        return cls(Schedule.of(config), Curriculum.of(config))

    def to_dict(self, log_sizes: Mapping[str, int]) -> dict[str, Any]:
        """JSON-ready state (the trainer part of ``training_state.json``); ``log_sizes``:
        the byte size of each log file at this point, to truncate them to on resume."""
        return {
            "env_steps": self.env_steps,
            "episodes": self.episodes,
            "wall_time": self.wall_time,
            "cpu_time": self.cpu_time,
            "timing": self.timing,
            **self.schedule.to_dict(),
            "history": self.curriculum.to_dict(),
            "recent_returns": list(self.recent_returns),
            "recent_success": list(self.recent_success),
            "loss_acc": self.loss_acc,
            "best": self.best,
            "evals": self.evals,
            "episodes_in_progress": [
                asdict(ep) | {"obs": [float(v) for v in obs]}
                for ep, obs in zip(self.episodes_in_progress, self.obs, strict=True)
            ],
            "log_sizes": dict(log_sizes),
        }

    def load(self, state: Mapping[str, Any]) -> None:
        """Restore the state saved by ``to_dict`` (the observation comes from the replay)."""
        self.env_steps = int(state["env_steps"])
        self.episodes = int(state["episodes"])
        self.wall_time = float(state["wall_time"])
        self.cpu_time = float(state.get("cpu_time", 0.0))
        self.timing = dict(state["timing"])
        self.schedule.load(state)
        self.curriculum.load(state["history"])
        self.recent_returns = deque(state["recent_returns"], maxlen=SUCCESS_WINDOW)
        self.recent_success = deque(state["recent_success"], maxlen=SUCCESS_WINDOW)
        self.loss_acc = {k: list(v) for k, v in state["loss_acc"].items()}
        self.best = state["best"]
        self.evals = list(state["evals"])
        saved = state.get("episodes_in_progress")
        if saved is None:  # a checkpoint of the one-env loop
            saved = [state["episode"]]
        self.episodes_in_progress = [EpisodeProgress(**ep) for ep in saved]
        self.obs = np.array([ep.obs for ep in self.episodes_in_progress], dtype=np.float32)


def truncate_logs(out: Path, log_sizes: Mapping[str, int]) -> None:
    """Cut each log in ``out`` back to its size at the checkpoint."""
    for name, size in log_sizes.items():
        path = out / name
        if path.exists() and path.stat().st_size > size:
            with AppendFile(path) as fh:  # never through a link planted in the run directory
                fh.cut(size)  # drop what was logged after the checkpoint


def rebuild_plans(episodes: list[EpisodeProgress]) -> list[dict[str, Any]]:
    """What each env re-runs on resume (``D3DWAEnv.rebuild``) to stand where it stood."""
    plans = []
    for ep in episodes:
        state = ep.rng_before if ep.rng_before is not None else _rng_state_of_seed(ep.reset_seed)  # type: ignore[arg-type]
        plans.append(
            {"rng_state": state, "actions": list(ep.actions), "task_weights": ep.task_weights}
        )
    return plans


def check_rebuilt(obs: np.ndarray, episodes: list[EpisodeProgress], where: Path) -> None:
    """TrainingError unless each rebuilt episode reached its saved observation (the
    simulator was not deterministic); ``where`` names the checkpoint."""
    for i, ep in enumerate(episodes):
        if ep.finished:
            continue
        if not np.array_equal(obs[i], np.asarray(ep.obs, dtype=np.float32)):
            raise TrainingError(
                f"{where}: replaying env {i}'s episode in progress ({len(ep.actions)} steps) "
                "did not reproduce its saved observation"
            )


def run_summary(
    progress: TrainingProgress, config: TrainConfig, out: Path, agent: Any, status: str
) -> dict[str, Any]:
    """The run's ``summary.json``: status, counters, throughput, timing, evaluations."""
    p, t = progress, progress.timing
    latest = checkpoint_dir(out, "latest")
    return {
        "status": status,
        "method": config.method,
        "run_dir": str(out),
        "env_steps": p.env_steps,
        "train_steps": agent.train_steps,
        "episodes": p.episodes,
        "wall_time_s": round(p.wall_time, 2),
        "cpu_time_s": round(p.cpu_time, 2),
        "steps_per_s": round(p.env_steps / p.wall_time, 2) if p.wall_time else None,
        "n_envs": config.n_envs,
        "env_steps_per_s": _env_rate(p.env_steps, config.n_envs, t),
        "updates_per_s": round(agent.train_steps / t["learn"], 2) if t["learn"] else None,
        "timing_s": {k: round(v, 2) for k, v in t.items()},
        "epsilon": agent.epsilon(),
        "best_eval": p.best,
        "final_eval": p.evals[-1] if p.evals else None,
        "policy": str(out / POLICY_DIR) if status == "done" else None,
        "resume": str(latest),
    }


def _env_rate(env_steps: int, n_envs: int, timing: Mapping[str, float]) -> float | None:
    """Env steps per second the n envs sustain: n / (mean seconds of one env's step)."""
    seconds = timing.get("env/step") or timing.get("env")
    return round(n_envs * env_steps / seconds, 2) if seconds else None
