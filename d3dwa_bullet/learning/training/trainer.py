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
"interrupted" (a second Ctrl-C aborts at once, saving nothing). A Ctrl-C during the final
evaluation lets it finish, saves ``latest`` with it and returns "interrupted" too; the
resume then only saves ``final`` and the policy.
"""

from __future__ import annotations

import os
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
import d3dwa_bullet.learning.training.warm_start as warm_start
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.errors import TrainingError
from d3dwa_bullet.learning.agents.checkpoint import Agent
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.training.collector import Collector, env_seeds
from d3dwa_bullet.learning.training.config import TrainConfig, make_agent, make_env
from d3dwa_bullet.learning.training.interrupt import StopOnInterrupt
from d3dwa_bullet.learning.training.lock_step import feed, step_envs
from d3dwa_bullet.learning.training.logs import MetricsLog
from d3dwa_bullet.learning.training.state import (
    EpisodeProgress,
    TrainingProgress,
    check_rebuilt,
    rebuild_plans,
    run_summary,
    truncate_logs,
)


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
            if not run_dir.has_checkpoint(self.out):
                print(
                    f"d3dwa: {self.out} stopped before its first checkpoint; "
                    "training it again from step 0",
                    file=sys.stderr,
                )
                run_dir.clear_before_first_checkpoint(self.out)
                resume = False
        else:
            config = run_dir.check_new_run(self.out, config)
        self.warm_start = None if resume else warm_start.source(config)
        """The network a new run starts from (``init_policy``), checked before any work."""
        self.config = config
        self.resume = resume
        self.progress = TrainingProgress.start(config)
        self._tau_slot = {h: i for i, h in enumerate(config.actions.horizons)}
        """Horizon -> its slot in an episode's tau_counts."""
        """Counters, schedule, curriculum, episode in progress: what ``latest`` saves."""
        self._start = time.perf_counter()
        self._wall0 = 0.0

    # --- the loop ------------------------------------------------------------------------

    def _task_weights(self, tasks: tuple[str, ...]) -> list[float] | None:
        c = self.progress.curriculum
        return c.weights(tasks) if c.mode == "adaptive" else None

    def _new_episode(self, weights: list[float] | None) -> EpisodeProgress:
        ep = EpisodeProgress(task_weights=weights)
        ep.tau_counts = [0] * len(self.config.actions.horizons)
        return ep

    def _start_envs(self, collector: Collector, tasks: tuple[str, ...]) -> np.ndarray:
        """First episodes of a new run, or every env's episode rebuilt on resume."""
        p, n = self.progress, collector.n
        if not self.resume:
            weights = self._task_weights(tasks)
            p.episodes_in_progress = [self._new_episode(weights) for _ in range(n)]
            return collector.reset_all(env_seeds(self.config.seed, n), weights)
        if len(p.episodes_in_progress) != n:
            raise TrainingError(
                f"{self.latest}: saved with {len(p.episodes_in_progress)} envs, resumed with "
                f"n_envs = {n}; resume with the run's own n_envs"
            )
        obs = collector.rebuild(rebuild_plans(p.episodes_in_progress))
        check_rebuilt(obs, p.episodes_in_progress, self.latest)
        finished = np.array([ep.finished for ep in p.episodes_in_progress])
        if finished.any():  # the budget ran out as these ended: their next episode starts now
            weights = self._task_weights(tasks)
            obs = collector.reset_some(finished, weights)
            for i in np.flatnonzero(finished):
                p.episodes_in_progress[i] = self._new_episode(weights)
        return obs

    def _save_latest(self, agent: Agent, logs: MetricsLog, collector: Collector) -> None:
        t0 = time.perf_counter()
        p = self.progress
        for ep, state in zip(p.episodes_in_progress, collector.reset_rng_states(), strict=True):
            ep.rng_before = state
        checkpoints.save_latest(self.out, agent, self.config, p, logs)
        p.timing["checkpoint"] += time.perf_counter() - t0

    def save_policy(self, name: str, agent: Agent, extra: Mapping[str, Any]) -> Path:
        return checkpoints.save_policy(self.out, name, agent, self.config, self.progress, extra)

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
            if self.warm_start is not None:
                warm_start.apply(agent, self.warm_start)  # type: ignore[arg-type]
            run_dir.write_config(self.out, c)
            run_dir.write_run_info(
                self.out, c, {"init_policy": self.warm_start.record()} if self.warm_start else {}
            )
        t_setup = time.perf_counter()
        if isinstance(agent, D3QNAgent):
            agent.optimizer  # noqa: B018  # built now: its one-off torch import is not an update's cost
        logs = MetricsLog(self.out)
        self._sampler_env = make_env(c)  # the task list and its probabilities, for the logs
        tasks = self._sampler_env.tasks
        collector = Collector(c, where=str(self.out))
        p.timing["setup"] = p.timing.get("setup", 0.0) + time.perf_counter() - t_setup
        status = "done"
        start = self._start = time.perf_counter()
        wall0 = self._wall0 = p.wall_time
        cpu_start, cpu0 = time.process_time(), p.cpu_time
        bar = tqdm(total=c.total_steps, initial=min(p.env_steps, c.total_steps),
                   disable=not progress, unit="step", desc=c.method,
                   mininterval=1.0 if os.isatty(2) else 30.0)  # fmt: skip
        try:
            with StopOnInterrupt() as stop:
                if p.env_steps < c.total_steps:
                    p.obs = self._start_envs(collector, tasks)
                while p.env_steps < c.total_steps:
                    if stop.requested:
                        status = "interrupted"
                        break
                    ended = self._lock_step(agent, collector, logs, bar, tasks)
                    # checked at episode ends, after the next episode's reset (as the docs say)
                    if (
                        ended
                        and p.env_steps < c.total_steps
                        and p.schedule.checkpoint.take(p.env_steps)
                    ):
                        self._clock(wall0, start, cpu0, cpu_start)
                        self._save_latest(agent, logs, collector)
                if status == "done" and isinstance(agent, D3QNAgent):
                    t0 = time.perf_counter()
                    self._log_losses(agent.update_pending())  # the last transitions' updates
                    p.timing["learn"] += time.perf_counter() - t0
                self._clock(wall0, start, cpu0, cpu_start)
                if (
                    status == "done"
                    and c.eval_every
                    and (not p.evals or p.evals[-1]["step"] != p.env_steps)
                ):
                    self._evaluate_and_keep(logs, agent, bar)
                self._save_latest(agent, logs, collector)
                if stop.requested:  # Ctrl-C during the final evaluation: resume ends the run
                    status = "interrupted"
                if status == "done":
                    final_eval = p.evals[-1] if p.evals else None
                    self.save_policy("final", agent, {"selected": "final", "eval": final_eval})
                    keep = "best" if c.keep == "best" and p.best is not None else "final"
                    checkpoints.export_policy(self.out, self.out / run_dir.POLICY_DIR, keep)
                self._stage_timing(agent, collector)
        finally:
            bar.close()
            collector.close()
            logs.close()
        summary = self.summary(agent, status)
        run_dir.write_summary(self.out, summary)
        return summary

    def _clock(self, wall0: float, start: float, cpu0: float, cpu_start: float) -> None:
        self.progress.wall_time = wall0 + time.perf_counter() - start
        self.progress.cpu_time = cpu0 + time.process_time() - cpu_start

    def _lock_step(
        self, agent: Agent, collector: Collector, logs: MetricsLog, bar: Any, tasks: tuple[str, ...]
    ) -> bool:
        """One step of every env: actions for all in one batch, the learner's due gradient
        steps while the envs simulate, then each env's transition in env order. True if an
        episode ended."""
        c, p = self.config, self.progress
        timing, perf = p.timing, time.perf_counter
        step = step_envs(agent, collector, p.obs, self._log_losses, timing)
        actions, rewards = step.actions, step.rewards
        done = np.zeros(collector.n, dtype=bool)
        tau_slot = self._tau_slot
        for i in range(collector.n):
            if p.env_steps >= c.total_steps:  # the budget ends inside this lock-step
                break
            t5 = perf()
            self._log_losses(feed(agent, step.transition(i), i))
            timing["learn"] += perf() - t5
            p.env_steps += 1
            bar.update(1)
            ep, info = p.episodes_in_progress[i], step.infos[i]
            ep.actions.append(int(actions[i]))
            ep.ret += float(rewards[i])
            ep.tau_counts[tau_slot[info["tau"]]] += 1
            ep.fallbacks += int(info["fallback"])
            if p.schedule.log.take(p.env_steps):
                self._log_scalars(logs, agent, tasks)
            if step.done[i]:
                ep.finished = True
                self._end_episode(logs, agent, info, bar, ep)
                done[i] = True
        p.obs = step.next_obs
        if done.any():
            if p.schedule.eval.take(p.env_steps):
                self._evaluate_and_keep(logs, agent, bar)
            if p.env_steps < c.total_steps:
                t6 = perf()
                weights = self._task_weights(tasks)
                p.obs = collector.reset_some(done, weights)
                for i in np.flatnonzero(done):
                    p.episodes_in_progress[i] = self._new_episode(weights)
                timing["env"] += perf() - t6
        return bool(done.any())

    def _task_probabilities(self, weights: list[float] | None) -> np.ndarray:
        env = self._sampler_env
        if weights is not None:
            env.set_task_weights(weights)
        return env.task_probabilities

    def _log_losses(self, updates: list[dict[str, float]]) -> None:
        acc = self.progress.loss_acc
        for logs_step in updates:
            if "losses/td_error" in logs_step:  # tabular: log 0.5 td^2 as its TD loss
                td = logs_step["losses/td_error"]
                logs_step = {"losses/td_loss": 0.5 * td * td, "losses/td_abs": abs(td)}
            for tag, value in logs_step.items():
                a = acc.setdefault(tag, [0.0, 0])
                a[0] += value
                a[1] += 1

    def _stage_timing(self, agent: Agent, collector: Collector) -> None:
        """Add the envs' stage seconds (env/...) and the learner's (learn/...) to the timing."""
        t = self.progress.timing
        for stage, s in collector.stage_seconds().items():
            t[f"env/{stage}"] = t.get(f"env/{stage}", 0.0) + s
        for part, s in getattr(agent, "timing", {}).items():
            t[f"learn/{part}"] = t.get(f"learn/{part}", 0.0) + s

    def _end_episode(
        self, logs: MetricsLog, agent: Any, info: Mapping[str, Any], bar: Any, ep: EpisodeProgress
    ) -> None:
        p = self.progress
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

    def _log_scalars(self, logs: MetricsLog, agent: Any, tasks: tuple[str, ...]) -> None:
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
        weights = self._task_weights(tasks)
        for task, prob in zip(tasks, self._task_probabilities(weights), strict=True):
            logs.scalar(step, f"curriculum/p_{task}", prob)
        logs.flush()

    def _evaluate_and_keep(self, logs: MetricsLog, agent: Any, bar: Any) -> None:
        p = self.progress
        t0 = time.perf_counter()
        worlds = len(self.config.eval_worlds) * len(self.config.eval_seeds)
        bar.set_postfix_str(f"evaluating: {worlds} greedy episodes", refresh=True)
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
        return run_summary(self.progress, self.config, self.out, agent, status)


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
    BusyError if another process is training into ``out_dir`` (:mod:`d3dwa_bullet.dir_lock`):
    the directory is locked before anything is read or written in it.
    """
    with locked_dir(out_dir):
        return Trainer(config, out_dir, resume).run(progress)
