"""Experience collection on every core: ``n_envs`` training envs stepped in lock-step.

The envs live behind Gymnasium's vector API with autoreset disabled (the trainer resets an
env itself, after logging its episode and with the curriculum's current task weights):

- ``n_envs == 1``, or ``vector: sync``: a ``SyncVectorEnv`` in this process;
- otherwise an ``AsyncVectorEnv`` of spawned worker processes, observations in shared
  memory. ``step_async`` returns at once, so the learner takes its gradient steps while the
  workers simulate, and ``step_wait`` collects the results.

Both give the same transitions for the same (seed, n_envs): each env draws its episodes from
its own seeded RNG, actions are chosen for all envs in one batch, and the trainer consumes
the results in env order. A worker that dies or stops answering is a ``TrainingError``
naming it (never a hang); the run's last good checkpoint is untouched.
"""

from __future__ import annotations

import functools
import multiprocessing
import signal
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import cv2
import gymnasium
import numpy as np
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv, VectorEnv

from d3dwa_bullet.errors import TrainingError
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training.config import TrainConfig, check_run_limits, make_env

WORKER_TIMEOUT_S = 300.0
"""A worker silent this long (one lock-step is milliseconds) is taken as hung."""
_LOST = (EOFError, BrokenPipeError, ConnectionError, multiprocessing.TimeoutError, TimeoutError)


def env_seeds(seed: int, n_envs: int) -> list[int]:
    """The first reset seed of each env, from the run seed (env 0's is the one-env seed)."""
    seeds = [int(np.random.SeedSequence([int(seed), 1]).generate_state(1)[0])]
    for i in range(1, n_envs):
        seeds.append(int(np.random.SeedSequence([int(seed), 1, i]).generate_state(1)[0]))
    return seeds


def _worker_env(config: TrainConfig) -> D3DWAEnv:
    """The env of one worker process: Ctrl-C is the parent's to handle (it saves a
    checkpoint), and OpenCV's distance transform stays on one thread per process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    cv2.setNumThreads(1)
    return make_env(config)


def _info_rows(infos: Mapping[str, Any], n: int) -> list[dict[str, Any]]:
    """A vector env's merged info dict back to one dict per env."""
    rows: list[dict[str, Any]] = [{} for _ in range(n)]
    for key, values in infos.items():
        if key.startswith("_"):
            continue
        mask = infos.get(f"_{key}")
        for i in range(n):
            if mask is None or mask[i]:
                value = values[i]
                rows[i][key] = value.item() if isinstance(value, np.generic) else value
    return rows


class Collector:
    """The training envs of a run, stepped together (module docstring)."""

    def __init__(
        self,
        config: TrainConfig,
        where: str = "",
        env_fn: Callable[[], gymnasium.Env] | None = None,
    ) -> None:
        """``env_fn``: builds each env instead of ``make_env(config)`` (picklable for
        ``vector: async``); for tests that drive the learner on another MDP."""
        check_run_limits(config)  # before a process starts or a buffer is allocated
        self.n = int(config.n_envs)
        self.where = where
        self._broken = False
        self._pending = np.zeros(self.n, dtype=np.int64)
        factory: Callable[[], gymnasium.Env]
        if env_fn is not None:
            factory = env_fn
        else:
            factory = functools.partial(_worker_env if self._async(config) else make_env, config)
        fns = [factory] * self.n
        self.envs: VectorEnv
        if self._async(config):
            self.envs = self._guard(
                AsyncVectorEnv, fns, shared_memory=True, context="spawn", daemon=True,
                autoreset_mode=AutoresetMode.DISABLED,
            )  # fmt: skip
        else:
            self.envs = SyncVectorEnv(fns, autoreset_mode=AutoresetMode.DISABLED)

    @staticmethod
    def _async(config: TrainConfig) -> bool:
        return config.n_envs > 1 and config.vector == "async"

    # --- the vector API, with lost workers made TrainingError ----------------------------

    def _guard(self, fn: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except _LOST as err:
            self._broken = True
            raise TrainingError(self._lost_message(err)) from err

    def _lost_message(self, err: BaseException) -> str:
        dead = [
            f"worker {i} (exit code {p.exitcode})"
            for i, p in enumerate(getattr(getattr(self, "envs", None), "processes", []))
            if not p.is_alive()
        ]
        what = ", ".join(dead) if dead else f"a worker did not answer ({type(err).__name__})"
        return (
            f"{self.where}: environment {what} died mid-run; the last checkpoint is kept, "
            f"continue with `d3dwa train --resume --out {self.where}`"
        )

    def reset_all(self, seeds: Sequence[int], task_weights: list[float] | None) -> np.ndarray:
        """First reset of every env with its seed; (n, obs_dim) observations."""
        options = {} if task_weights is None else {"task_weights": task_weights}
        obs, _ = self._guard(self.envs.reset, seed=list(seeds), options=options)
        return np.array(obs)

    def reset_some(self, mask: np.ndarray, task_weights: list[float] | None) -> np.ndarray:
        """Reset the envs where ``mask`` is True (their own RNG draws the next episode);
        returns all n observations (the others unchanged)."""
        options: dict[str, Any] = {"reset_mask": np.asarray(mask, dtype=np.bool_)}
        if task_weights is not None:
            options["task_weights"] = task_weights
        obs, _ = self._guard(self.envs.reset, options=options)
        return np.array(obs)

    def step_async(self, actions: np.ndarray) -> None:
        """Start a step of every env (in the workers; an in-process env steps at the wait)."""
        actions = np.asarray(actions, dtype=np.int64)
        if isinstance(self.envs, AsyncVectorEnv):
            self._guard(self.envs.step_async, actions)
        else:
            self._pending = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        """(obs (n, d), rewards (n,), terminated (n,), truncated (n,), one info dict per env)."""
        if isinstance(self.envs, AsyncVectorEnv):
            out = self._guard(self.envs.step_wait, timeout=WORKER_TIMEOUT_S)
        else:
            out = self.envs.step(self._pending)
        obs, rewards, terminated, truncated, infos = out
        return (
            np.array(obs),
            np.asarray(rewards, dtype=np.float64),
            np.asarray(terminated, dtype=bool),
            np.asarray(truncated, dtype=bool),
            _info_rows(infos, self.n),
        )

    def reset_rng_states(self) -> list[dict[str, Any]]:
        """Each env's RNG state just before its current episode's draw."""
        return list(self._guard(self.envs.get_attr, "reset_rng_state"))

    def rebuild(self, plans: Sequence[Mapping[str, Any]]) -> np.ndarray:
        """Re-run each env's saved episode (``D3DWAEnv.rebuild``); (n, obs_dim)."""
        self._guard(self.envs.set_attr, "rebuild_plan", list(plans))
        obs = self._guard(self.envs.call, "rebuild_from_plan")
        return np.array(obs)

    def stage_seconds(self) -> dict[str, float]:
        """Seconds per env stage summed over the envs (CPU seconds of the workers)."""
        total: dict[str, float] = {}
        for seconds in self._guard(self.envs.call, "stage_seconds"):
            for stage, s in seconds.items():
                total[stage] = total.get(stage, 0.0) + s
        return total

    def close(self) -> None:
        envs = getattr(self, "envs", None)
        if envs is None:
            return
        if isinstance(envs, AsyncVectorEnv) and self._broken:
            # A lost worker leaves a call pending on a dead pipe, where the vector env's own
            # close would fail (and warn): stop the rest of the workers directly.
            for process in envs.processes:
                if process.is_alive():
                    process.terminate()
            for process in envs.processes:
                process.join(timeout=10)
            for pipe in envs.parent_pipes:
                if pipe is not None:
                    pipe.close()
            envs.closed = True
            return
        envs.close()
