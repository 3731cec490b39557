"""The periodic greedy evaluation of a training run, and how evaluations are compared.

Every ``eval_every`` env steps (at the next episode end, and once at the end of the
budget) the greedy policy of the agent runs one episode per evaluation world and seed,
with the ``eval_noise`` profile. Evaluation worlds are training worlds (or generated
layouts): the evaluation-only groups stay unseen. The best evaluation so far (success
rate, then fewer collisions, then mean return) is what ``keep: best`` ships.

Every evaluation also measures value calibration (docs/design/agent.md#value-calibration): the
agent's mean Q over the (s, a) pairs its greedy episodes visited, against the discounted
return those pairs went on to earn, with the agent's own gamma.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.policy import Policy, greedy_policy, taken_q_values
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training.config import TrainConfig, make_env
from d3dwa_bullet.learning.training.logs import MetricsLog
from d3dwa_bullet.learning.value_calibration import calibrate


@dataclass
class GreedyEpisode:
    """One greedy episode as the learner saw it: the observations it acted on, the actions
    it took and the rewards it earned, one entry per decision (an env step)."""

    world: str
    outcome: str
    seconds: float
    obs: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray


def greedy_episode(
    env: D3DWAEnv, policy: Policy, world: str, noise: str, seed: int
) -> GreedyEpisode:
    """Run ``policy`` for one episode of ``env`` on ``world`` with episode seed ``seed``."""
    obs, info = env.reset(options={"world": world, "noise": noise, "episode_seed": seed})
    seen, taken, rewards, control_steps = [], [], [], 0
    while True:
        action = policy(obs)
        seen.append(obs)
        taken.append(action)
        obs, r, terminated, truncated, info = env.step(action)
        rewards.append(float(r))
        control_steps += info["control_steps"]
        if terminated or truncated:
            break
    seconds = control_steps / env.episode_config.sim.control_hz
    return GreedyEpisode(
        info["world"], info["outcome"], seconds, np.stack(seen), np.array(taken), np.array(rewards)
    )


def evaluate(agent: D3QNAgent | DQDWAAgent, config: TrainConfig, step: int) -> dict[str, Any]:
    """Greedy episodes of ``agent`` on the config's evaluation worlds and seeds.

    Returns {"step", "success_rate", "collision_rate", "mean_return", "mean_time_s" (of
    the successful episodes, None if none), "outcomes": world -> outcome per seed,
    "values": the value calibration's figures (ValueCalibration.to_dict)}.
    """
    c = config
    policy = greedy_policy(agent)
    env = make_env(c, worlds=c.eval_worlds[:1])
    try:
        episodes = [
            greedy_episode(env, policy, world, c.eval_noise, seed)
            for world in c.eval_worlds
            for seed in c.eval_seeds
        ]
    finally:
        env.close()
    outcomes: dict[str, list[str]] = {}
    for e in episodes:
        outcomes.setdefault(e.world, []).append(e.outcome)
    flat = [e.outcome for e in episodes]
    times = [e.seconds for e in episodes if e.outcome == "goal"]
    values = calibrate(
        [taken_q_values(agent, e.obs, e.actions) for e in episodes],
        [e.rewards for e in episodes],
        agent.config.gamma,
    )
    return {
        "step": step,
        "success_rate": flat.count("goal") / len(flat),
        "collision_rate": flat.count("collision") / len(flat),
        "mean_return": float(np.mean([e.rewards.sum() for e in episodes])),
        "mean_time_s": float(np.mean(times)) if times else None,
        "outcomes": outcomes,
        "values": values.to_dict(),
    }


def log_evaluation(logs: MetricsLog, step: int, result: Mapping[str, Any]) -> None:
    """The eval/ scalars of one evaluation (overall and per world), flushed."""
    logs.scalar(step, "eval/success_rate", result["success_rate"])
    logs.scalar(step, "eval/collision_rate", result["collision_rate"])
    logs.scalar(step, "eval/mean_return", result["mean_return"])
    values = result.get("values")
    if values:
        logs.scalar(step, "eval/mean_q", values["mean_q"])
        logs.scalar(step, "eval/discounted_return", values["mean_return"])
    for world, outs in result["outcomes"].items():
        logs.scalar(step, f"eval/{world}_success", outs.count("goal") / len(outs))
    logs.flush()  # the learning curve reads the file: the final evaluation must be on it


def score(result: Mapping[str, Any]) -> list[float]:
    """Sort key of an evaluation: success rate, then fewer collisions, then mean return."""
    return [result["success_rate"], -result["collision_rate"], result["mean_return"]]


def describe(step: int, result: Mapping[str, Any]) -> str:
    """One progress line: the rates, the mean return and every world's outcomes."""
    per_world = " ".join(f"{w}:{'/'.join(o)}" for w, o in result["outcomes"].items())
    return (
        f"step {step}: greedy eval success {result['success_rate']:.2f}, "
        f"collisions {result['collision_rate']:.2f}, return {result['mean_return']:.3f}, "
        f"{_values_text(result.get('values'))} [{per_world}]"
    )


def _values_text(values: Mapping[str, Any] | None) -> str:
    if not values:
        return "mean Q -"
    return f"mean Q {values['mean_q']:.3f} vs discounted return {values['mean_return']:.3f}"
