"""Cross-check of the D3QN's value calibration against a reference learner: SB3's DQN.

Stable-Baselines3's DQN trains on the env the product trains on (``make_env`` of the loaded
training config: the same worlds, generator styles, noise and reward scale), with the
config's agent hyper-parameters wherever SB3 has them. Its greedy policy then runs one
episode per evaluation world and seed (the config's ``eval_worlds`` / ``eval_seeds`` /
``eval_noise``, as the trainer's greedy evaluation does), and the mean Q of the visited
(s, a) from SB3's ``q_net`` is set against the discounted return they earned
(``value_calibration.calibrate``, the config's gamma). If SB3's values track its returns
where the D3QN's run far above them, the overestimation is the D3QN's, not the task's.

What is matched: gamma, n-step returns (``n_step``), learning rate, batch size, replay size
(capped at the budget), learning_starts, one gradient step every ``train_freq`` env steps, a
Polyak update with ``tau_soft`` after every gradient step, Huber loss (SB3's smooth L1:
delta 1), gradient clip, hidden widths, and the exponential epsilon schedule in gradient
steps (installed as SB3's exploration schedule). What is not: SB3's DQN is neither dueling
nor double (its target is r + gamma max_a Q_target(s', a)); it runs one env (the config's
n_envs is not mirrored; the update-to-data ratio per env step is the same); the trainer's
adaptive curriculum is not run (tasks are drawn with the env's base probabilities, as the
uniform curriculum does); truncation by the time limit is bootstrapped (SB3's
``handle_timeout_termination``), as the D3QN does.

    python -m tools.experiments.sb3_crosscheck --steps 40000 --seed 0 --json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

try:  # the optional `sb3` extra; without it main says so in one line (tools.entry)
    from stable_baselines3 import DQN
    from stable_baselines3.common.callbacks import BaseCallback
except ModuleNotFoundError as missing:
    SB3_MISSING: ModuleNotFoundError | None = missing
    DQN = Any  # type: ignore[misc,assignment]
    BaseCallback = object  # type: ignore[misc,assignment]
else:
    SB3_MISSING = None

from d3dwa_bullet.cli.options import split_list
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.learning.agents.d3qn import D3QNConfig, exponential_epsilon
from d3dwa_bullet.learning.training.config import (
    TrainConfig,
    check_run_limits,
    load_train_config,
    make_env,
)
from d3dwa_bullet.learning.value_calibration import calibrate
from d3dwa_bullet.resources import configs_dir
from tools.entry import ToolParser, fail, tool_main

DEFAULT_CONFIG = "d3dwa.yaml"
"""The shipped training config whose env and agent block are mirrored (in configs/)."""


def sb3_hyperparameters(agent: D3QNConfig, steps: int) -> dict[str, Any]:
    """SB3 DQN keyword arguments matching the D3QN's config (module docstring)."""
    return {
        "gamma": agent.gamma,
        "learning_rate": agent.lr,
        "batch_size": agent.batch_size,
        "buffer_size": min(agent.buffer_size, max(steps, agent.batch_size)),
        "learning_starts": agent.learning_starts,
        "train_freq": agent.train_freq,
        "gradient_steps": 1,
        "n_steps": agent.n_step,  # n-step returns (SB3 >= 2.7): 1 is the one-step target
        "tau": agent.tau_soft,
        # SB3 updates the target every target_update_interval env steps: once per gradient step
        "target_update_interval": agent.train_freq,
        "max_grad_norm": agent.grad_clip,
        "exploration_initial_eps": agent.eps_start,
        "exploration_final_eps": agent.eps_end,
        "policy_kwargs": {"net_arch": list(agent.hidden)},
    }


def epsilon_schedule(agent: D3QNConfig, steps: int) -> Callable[[float], float]:
    """The D3QN's epsilon (exponential in gradient steps) as an SB3 schedule of the
    remaining progress: gradient steps = (env steps - learning_starts) / train_freq."""

    def schedule(progress_remaining: float) -> float:
        env_steps = (1.0 - progress_remaining) * steps
        grad_steps = max(0.0, env_steps - agent.learning_starts) // agent.train_freq
        return exponential_epsilon(int(grad_steps), agent.eps_start, agent.eps_end, agent.eps_decay)

    return schedule


class _Progress(BaseCallback):
    """A line on stderr every ``every`` env steps: steps, episodes, recent success, epsilon."""

    def __init__(self, every: int) -> None:
        super().__init__()
        self.every = every
        self.outcomes: list[str] = []

    def _on_step(self) -> bool:
        for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
            if done:
                self.outcomes.append(str(info.get("outcome")))
        if self.num_timesteps % self.every == 0:
            recent = self.outcomes[-50:]
            rate = recent.count("goal") / len(recent) if recent else math.nan
            eps = getattr(self.model, "exploration_rate", math.nan)  # a DQN's own attribute
            print(
                f"sb3_crosscheck: {self.num_timesteps} steps, {len(self.outcomes)} episodes, "
                f"success (last 50) {rate:.2f}, eps {eps:.3f}",
                file=sys.stderr,
                flush=True,
            )
        return True


def train(config: TrainConfig, steps: int, seed: int, progress_every: int = 5000) -> DQN:
    """SB3 DQN trained ``steps`` env steps on ``make_env(config)``."""
    agent = config.agent
    assert isinstance(agent, D3QNConfig)
    if agent.torch_threads:
        torch.set_num_threads(agent.torch_threads)
    model = DQN(
        "MlpPolicy",
        make_env(config),
        seed=seed,
        device="cpu",
        verbose=0,
        **sb3_hyperparameters(agent, steps),
    )
    model.exploration_schedule = epsilon_schedule(agent, steps)
    model.learn(total_timesteps=steps, callback=_Progress(progress_every))
    return model


def q_of(model: DQN, obs: np.ndarray) -> np.ndarray:
    """SB3's online Q-values, obs (T, d) -> (T, n_actions) float64."""
    with torch.no_grad():
        x = torch.as_tensor(np.asarray(obs, dtype=np.float32))
        return model.q_net(x).numpy().astype(np.float64)


def greedy_episodes(model: DQN, config: TrainConfig) -> list[dict[str, Any]]:
    """One greedy episode per evaluation world and seed, as the trainer's greedy evaluation
    runs them; each with its outcome, rewards and the Q of every (s, a) it took."""
    env = make_env(config, worlds=config.eval_worlds[:1])
    episodes = []
    try:
        for world in config.eval_worlds:
            for seed in config.eval_seeds:
                obs, info = env.reset(
                    options={"world": world, "noise": config.eval_noise, "episode_seed": seed}
                )
                q_taken, rewards = [], []
                while True:
                    q = q_of(model, obs[None])[0]
                    action = int(np.argmax(q))
                    q_taken.append(float(q[action]))
                    obs, r, terminated, truncated, info = env.step(action)
                    rewards.append(float(r))
                    if terminated or truncated:
                        break
                episodes.append({
                    "world": str(info["world"]), "seed": int(seed),
                    "outcome": str(info["outcome"]), "steps": len(rewards),
                    "rewards": rewards, "q_taken": q_taken,
                })  # fmt: skip
    finally:
        env.close()
    return episodes


def crosscheck(config: TrainConfig, steps: int, seed: int) -> dict[str, Any]:
    """Train, evaluate greedily, calibrate; the JSON-ready figures."""
    agent = config.agent
    assert isinstance(agent, D3QNConfig)
    t0 = time.perf_counter()
    model = train(config, steps, seed)
    train_s = time.perf_counter() - t0
    vec_env = model.get_env()
    if vec_env is not None:
        vec_env.close()
    episodes = greedy_episodes(model, config)
    values = calibrate(
        [e["q_taken"] for e in episodes], [e["rewards"] for e in episodes], agent.gamma
    )
    outcomes = [e["outcome"] for e in episodes]
    return {
        "learner": "stable_baselines3.DQN (not dueling, not double)",
        "method": config.method,
        "steps": steps,
        "seed": seed,
        "gamma": agent.gamma,
        "hyperparameters": sb3_hyperparameters(agent, steps),
        "train_seconds": round(train_s, 1),
        "gradient_steps": int(model._n_updates),
        "eval_worlds": list(config.eval_worlds),
        "success_rate": outcomes.count("goal") / len(outcomes),
        "collision_rate": outcomes.count("collision") / len(outcomes),
        "mean_return": float(np.mean([sum(e["rewards"]) for e in episodes])),
        "values": values.to_dict(),
        "verdict": values.describe(),
        "episodes": episodes,
    }


def _config(args: argparse.Namespace) -> TrainConfig:
    """The training config to mirror, with the tool's overrides; D3DWAError if bad."""
    if args.steps < 1:
        raise D3DWAError(f"--steps must be >= 1, got {args.steps}")
    if args.seed < 0:
        raise D3DWAError(f"--seed must be >= 0, got {args.seed}")
    path = Path(args.config) if args.config else configs_dir() / DEFAULT_CONFIG
    overrides: dict[str, Any] = {"total_steps": args.steps, "seed": args.seed}
    if args.eval_worlds is not None:
        worlds = split_list(args.eval_worlds)
        if not worlds:
            raise D3DWAError(f"--eval-worlds: give at least one world, got {args.eval_worlds!r}")
        overrides["eval_worlds"] = worlds
    config = load_train_config(path, **overrides)
    if config.family != "d3qn":
        raise D3DWAError(f"{path}: method {config.method!r} is not a D3QN method")
    if args.hidden is not None:
        try:
            hidden = tuple(int(h) for h in split_list(args.hidden))
        except ValueError as err:
            raise D3DWAError(f"--hidden: not a list of whole numbers: {args.hidden!r}") from err
        config = replace(config, agent=replace(config.agent, hidden=hidden))  # type: ignore[type-var]
    check_run_limits(config)
    return config


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", help=f"training config YAML (default: configs/{DEFAULT_CONFIG})")
    ap.add_argument("--steps", type=int, default=40_000, help="env steps of SB3's training")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-worlds", help="comma list instead of the config's eval_worlds")
    ap.add_argument("--hidden", help="comma list of hidden widths instead of the config's")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    if SB3_MISSING is not None:
        raise SB3_MISSING
    try:
        config = _config(args)
    except D3DWAError as err:
        fail("sb3_crosscheck", str(err))
    result = crosscheck(config, args.steps, args.seed)
    if args.json:
        print(json.dumps(result))
        return 0
    v = result["values"]
    ratio = "n/a" if v["ratio"] is None else f"{v['ratio']:.2f}"
    print(
        f"SB3 DQN, {args.steps} steps, seed {args.seed}, {len(result['episodes'])} greedy episodes"
    )
    print(f"  success rate            {result['success_rate']:.2f}")
    print(f"  mean Q of visited (s,a) {v['mean_q']:.4f}")
    print(f"  mean discounted return  {v['mean_return']:.4f}")
    print(f"  ratio Q / return        {ratio}")
    print(f"  {result['verdict']}")
    return 0 if all(math.isfinite(v[k]) for k in ("mean_q", "mean_return")) else 1


if __name__ == "__main__":
    sys.exit(main())
