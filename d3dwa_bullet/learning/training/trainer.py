"""The training loop: ``train(config, out_dir)`` runs one training of a learned method.

Loop: epsilon-greedy action -> env step -> ``agent.learn`` (store + one update when due).
Every ``log_every`` steps the loss, epsilon, throughput and curriculum scalars are
logged; every ``eval_every`` steps (at the next episode end) the greedy policy runs once
per evaluation world and seed (``greedy_eval``); every ``checkpoint_every`` steps (at
the next episode end) ``latest`` is saved (``schedule`` holds that cadence). Before each
episode the curriculum sets the task weights (``curriculum``). At the end of the budget
``checkpoints/final`` is saved and the kept policy exported to ``<out>/policy``
(``run_dir`` lists the files of a run).

``train(..., resume=True)`` continues a run exactly where its ``latest`` checkpoint left
it (``state``).

Failure safety: checkpoints are swapped in atomically; an exception in the loop saves
nothing (the last good ``latest`` stays); non-finite weights are never saved; Ctrl-C
(SIGINT) stops at the next step boundary, saves ``latest`` and returns with status
"interrupted" (a second Ctrl-C aborts at once, saving nothing).
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

import d3dwa_bullet.learning.training.checkpoints as checkpoints
import d3dwa_bullet.learning.training.greedy_eval as greedy_eval
import d3dwa_bullet.learning.training.run_dir as run_dir
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training.config import TrainConfig, make_agent, make_env
from d3dwa_bullet.learning.training.logs import MetricsLog
from d3dwa_bullet.learning.training.state import (
    EpisodeProgress,
    TrainingProgress,
    env_seed,
    replay_episode,
    truncate_logs,
)


class _Stop:
    """SIGINT -> a flag checked at step boundaries; a second SIGINT raises at once."""

    def __init__(self) -> None:
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> _Stop:
        try:
            self._previous = signal.signal(signal.SIGINT, self._handle)
        except ValueError:  # not the main thread: no handler, Ctrl-C behaves as usual
            self._previous = None
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


class Trainer:
    """One training run in ``out`` (see module docstring); ``run()`` returns the summary.

    ConfigError for a missing config, an existing run without ``resume``, or (resuming)
    nothing to resume or a config that differs from the run's in more than total_steps.
    """

    def __init__(
        self, config: TrainConfig | None, out: str | os.PathLike[str], resume: bool = False
    ):
        self.out = Path(out)
        self.latest = run_dir.checkpoint_dir(self.out, "latest")
        if resume:
            config = run_dir.resume_config(self.out, config)
        else:
            config = run_dir.check_new_run(self.out, config)
        self.config = config
        self.resume = resume
        self.progress = TrainingProgress.start(config)
        """Counters, schedule, curriculum, episode in progress: what ``latest`` saves."""
        self._start = time.perf_counter()
        self._wall0 = 0.0

    # --- checkpoints ---------------------------------------------------------------------

    def save_latest(self, agent: D3QNAgent | DQDWAAgent, logs: MetricsLog) -> None:
        t0 = time.perf_counter()
        checkpoints.save_latest(self.out, agent, self.config, self.progress, logs)
        self.progress.timing["checkpoint"] += time.perf_counter() - t0

    def save_policy(
        self, name: str, agent: D3QNAgent | DQDWAAgent, extra: Mapping[str, Any]
    ) -> Path:
        return checkpoints.save_policy(self.out, name, agent, self.config, self.progress, extra)

    # --- episodes ------------------------------------------------------------------------

    def _reset(self, env: D3DWAEnv, first: bool) -> np.ndarray:
        p = self.progress
        p.curriculum.apply(env)
        if first:
            seed = env_seed(self.config.seed)
            p.episode = EpisodeProgress(reset_seed=seed)
            obs, _ = env.reset(seed=seed)
        else:
            p.episode = EpisodeProgress(rng_before=env.np_random.bit_generator.state)
            obs, _ = env.reset()
        p.episode.tau_counts = [0] * len(self.config.actions.horizons)
        return obs

    def _rebuild_episode(self, env: D3DWAEnv) -> np.ndarray | None:
        self.progress.curriculum.apply(env)
        return replay_episode(env, self.progress.episode, self.latest)

    # --- the loop ------------------------------------------------------------------------

    def run(self, progress: bool = True) -> dict[str, Any]:
        c = self.config
        p = self.progress
        self.out.mkdir(parents=True, exist_ok=True)
        if self.resume:
            agent, state = checkpoints.load_latest(self.out, c)
            p.load(state)
            truncate_logs(self.out, state["log_sizes"])
            run_dir.write_config(self.out, c)  # total_steps may have been extended
        else:
            agent = make_agent(c)
            run_dir.write_config(self.out, c)
            run_dir.write_run_info(self.out, c)
        logs = MetricsLog(self.out)
        env = make_env(c)
        horizons = list(c.actions.horizons)
        tau_slot = {h: i for i, h in enumerate(horizons)}
        schedule = p.schedule
        status = "done"
        start = self._start = time.perf_counter()
        wall0 = self._wall0 = p.wall_time
        cpu_start, cpu0 = time.process_time(), p.cpu_time
        bar = tqdm(total=c.total_steps, initial=min(p.env_steps, c.total_steps),
                   disable=not progress, unit="step", desc=c.method,
                   mininterval=1.0 if os.isatty(2) else 30.0)  # fmt: skip
        try:
            with _Stop() as stop:
                obs = None
                if self.resume and p.env_steps < c.total_steps:
                    obs = self._rebuild_episode(env)
                if obs is None and p.env_steps < c.total_steps:
                    obs = self._reset(env, first=not self.resume)
                p.obs = obs
                perf = time.perf_counter
                timing = p.timing
                while p.env_steps < c.total_steps:
                    if stop.requested:
                        status = "interrupted"
                        break
                    t0 = perf()
                    action = agent.act(obs)
                    t1 = perf()
                    obs2, r, terminated, truncated, info = env.step(action)
                    t2 = perf()
                    logs_step = agent.learn(Transition(obs, action, r, obs2, terminated, truncated))
                    t3 = perf()
                    timing["act"] += t1 - t0
                    timing["env"] += t2 - t1
                    timing["learn"] += t3 - t2
                    p.env_steps += 1
                    bar.update(1)
                    ep = p.episode
                    ep.actions.append(int(action))
                    ep.ret += r
                    ep.tau_counts[tau_slot[info["tau"]]] += 1
                    ep.fallbacks += int(info["fallback"])
                    if "losses/td_error" in logs_step:  # tabular: log 0.5 td^2 as its TD loss
                        td = logs_step["losses/td_error"]
                        logs_step = {"losses/td_loss": 0.5 * td * td, "losses/td_abs": abs(td)}
                    for tag, value in logs_step.items():
                        acc = p.loss_acc.setdefault(tag, [0.0, 0])
                        acc[0] += value
                        acc[1] += 1
                    if schedule.log.take(p.env_steps):
                        self._log_scalars(logs, agent, env)
                    if terminated or truncated:
                        ep.finished = True
                        self._end_episode(logs, agent, info, bar)
                        if schedule.eval.take(p.env_steps):
                            self._evaluate_and_keep(logs, agent, bar)
                        # the next episode starts before the checkpoint, so a resume
                        # rebuilds it from the saved RNG with no steps to replay
                        obs = obs2
                        if p.env_steps < c.total_steps:
                            obs = self._reset(env, first=False)
                        p.obs = obs
                        if schedule.checkpoint.take(p.env_steps):
                            p.wall_time = wall0 + perf() - start
                            p.cpu_time = cpu0 + time.process_time() - cpu_start
                            self.save_latest(agent, logs)
                    else:
                        obs = p.obs = obs2
                p.wall_time = wall0 + time.perf_counter() - start
                p.cpu_time = cpu0 + time.process_time() - cpu_start
                if (
                    status == "done"
                    and c.eval_every
                    and (not p.evals or p.evals[-1]["step"] != p.env_steps)
                ):
                    self._evaluate_and_keep(logs, agent, bar)
                self.save_latest(agent, logs)
                if status == "done":
                    final_eval = p.evals[-1] if p.evals else None
                    self.save_policy("final", agent, {"selected": "final", "eval": final_eval})
                    keep = "best" if c.keep == "best" and p.best is not None else "final"
                    checkpoints.export_policy(self.out, self.out / run_dir.POLICY_DIR, keep)
        finally:
            bar.close()
            env.close()
            logs.close()
        summary = self.summary(agent, status)
        run_dir.write_summary(self.out, summary)
        return summary

    def _end_episode(self, logs: MetricsLog, agent: Any, info: Mapping[str, Any], bar: Any) -> None:
        p = self.progress
        ep = p.episode
        p.episodes += 1
        success = int(info["outcome"] == "goal")
        task = str(info["task"])
        if not info.get("route_start", False):  # the curriculum rates the tasks as evaluated
            p.curriculum.record(task, success)
        p.recent_success.append(success)
        p.recent_returns.append(ep.ret)
        step = p.env_steps
        n = len(ep.actions)
        horizons = self.config.actions.horizons
        tau_mean = sum(h * k for h, k in zip(horizons, ep.tau_counts, strict=True)) / max(n, 1)
        logs.episode({
            "step": step, "episode": p.episodes, "task": task, "world": info["world"],
            "noise": info["noise"], "route_start": bool(info.get("route_start", False)),
            "outcome": info["outcome"], "return": round(ep.ret, 6),
            "length": n, "epsilon": round(agent.epsilon(), 5), "tau_mean": round(tau_mean, 4),
            "fallbacks": ep.fallbacks,
            "wall_time": round(self._wall0 + time.perf_counter() - self._start, 2),
        })  # fmt: skip
        logs.scalar(step, "charts/episodic_return", ep.ret)
        logs.scalar(step, "charts/episodic_length", n)
        logs.scalar(step, "charts/success_rate", float(np.mean(p.recent_success)))
        logs.scalar(step, "charts/epsilon", agent.epsilon())
        logs.scalar(step, "planner/fallback_rate", ep.fallbacks / max(n, 1))
        logs.histogram(
            step, "planner/tau", {f"{h:g}": k for h, k in zip(horizons, ep.tau_counts, strict=True)}
        )
        bar.set_postfix_str(
            f"ep {p.episodes} {info['world']}: {info['outcome']}, "
            f"success {np.mean(p.recent_success):.2f}, eps {agent.epsilon():.3f}",
            refresh=False,
        )

    def _log_scalars(self, logs: MetricsLog, agent: Any, env: D3DWAEnv) -> None:
        p = self.progress
        step = p.env_steps
        for tag, (total, count) in sorted(p.loss_acc.items()):
            if count and tag != "charts/epsilon":
                logs.scalar(step, tag, total / count)
        p.loss_acc = {}
        logs.scalar(step, "charts/epsilon", agent.epsilon())
        elapsed = self._wall0 + time.perf_counter() - self._start
        if elapsed > 0:
            logs.scalar(step, "charts/sps", step / elapsed)
        for task, prob in zip(env.tasks, env.task_probabilities, strict=True):
            logs.scalar(step, f"curriculum/p_{task}", prob)
        logs.flush()

    def _evaluate_and_keep(self, logs: MetricsLog, agent: Any, bar: Any) -> None:
        p = self.progress
        t0 = time.perf_counter()
        result = greedy_eval.evaluate(agent, self.config, p.env_steps)
        p.timing["eval"] += time.perf_counter() - t0
        p.evals.append(result)
        greedy_eval.log_evaluation(logs, p.env_steps, result)
        if not bar.disable:  # progress on: one line per evaluation on stderr, above the bar
            bar.write(greedy_eval.describe(p.env_steps, result), file=sys.stderr)
        if p.best is None or greedy_eval.score(result) >= greedy_eval.score(p.best):
            p.best = result
            self.save_policy("best", agent, {"selected": "best", "eval": result})

    def summary(self, agent: Any, status: str) -> dict[str, Any]:
        p = self.progress
        t = p.timing
        return {
            "status": status,
            "method": self.config.method,
            "run_dir": str(self.out),
            "env_steps": p.env_steps,
            "train_steps": agent.train_steps,
            "episodes": p.episodes,
            "wall_time_s": round(p.wall_time, 2),
            "cpu_time_s": round(p.cpu_time, 2),
            "steps_per_s": round(p.env_steps / p.wall_time, 2) if p.wall_time else None,
            "env_steps_per_s": round(p.env_steps / t["env"], 2) if t["env"] else None,
            "updates_per_s": round(agent.train_steps / t["learn"], 2) if t["learn"] else None,
            "timing_s": {k: round(v, 2) for k, v in t.items()},
            "epsilon": agent.epsilon(),
            "best_eval": p.best,
            "final_eval": p.evals[-1] if p.evals else None,
            "policy": str(self.out / run_dir.POLICY_DIR) if status == "done" else None,
            "resume": str(self.latest),
        }


def train(
    config: TrainConfig | None,
    out_dir: str | os.PathLike[str],
    resume: bool = False,
    progress: bool = True,
) -> dict[str, Any]:
    """Run (or with ``resume=True`` continue) a training; returns the run summary.

    config: None when resuming takes the run's own config.json; given on resume, it must
    equal the saved one except for total_steps (to extend a run). ConfigError for a bad
    config, an existing run without ``resume``, or nothing to resume. The summary's
    "status" is "done" or "interrupted" (Ctrl-C: ``latest`` was saved, resume later).
    """
    return Trainer(config, out_dir, resume).run(progress)
