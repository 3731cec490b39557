"""One lock-step of the training envs, and the transitions the learner is given from it.

``step_envs`` chooses the actions of every env in one batch, starts the envs' step, takes
the D3QN's due gradient steps while they simulate, and collects the results; ``LockStep``
holds them and builds env ``i``'s ``Transition``: the observation its action was chosen in,
the reward, the observation the step reached (never the next episode's first one: the
envs are reset only after every transition was given), ``terminated`` for goal and
collision, and ``truncated`` for the time limit, which the learner keeps non-terminal.
``feed`` gives one transition to the learner.

The trainer's loop (``trainer.Trainer._lock_step``) and the learner's correctness test on
a tiny MDP with a closed-form Q* (tests/learning/test_learner_mdp.py) both go through
these, so the test checks the transitions a real run stores.
"""

from __future__ import annotations

import time
from collections.abc import Callable, MutableMapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from d3dwa_bullet.learning.agents.checkpoint import Agent
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.training.collector import Collector

Updates = list[dict[str, float]]
"""The logs of the gradient steps (or tabular updates) taken, in order."""


@dataclass(frozen=True)
class LockStep:
    """One step of ``n`` envs: every array's first axis is the env."""

    obs: np.ndarray
    """(n, obs_dim): the observations the actions were chosen in."""
    actions: np.ndarray
    """(n,) int64."""
    next_obs: np.ndarray
    """(n, obs_dim): the observations the step reached (before any reset)."""
    rewards: np.ndarray
    """(n,) float64."""
    terminated: np.ndarray
    """(n,) bool: goal or collision (no bootstrap)."""
    truncated: np.ndarray
    """(n,) bool: the time limit (bootstrapped)."""
    infos: list[dict[str, Any]]
    """One info dict per env."""

    @property
    def done(self) -> np.ndarray:
        """(n,) bool: the envs whose episode ended with this step."""
        return self.terminated | self.truncated

    def transition(self, i: int) -> Transition:
        """Env ``i``'s transition, as the learner stores it."""
        return Transition(self.obs[i], int(self.actions[i]), float(self.rewards[i]),
                          self.next_obs[i], bool(self.terminated[i]),
                          bool(self.truncated[i]))  # fmt: skip


def step_envs(
    agent: Agent,
    collector: Collector,
    obs: np.ndarray,
    on_updates: Callable[[Updates], None] | None = None,
    timing: MutableMapping[str, float] | None = None,
) -> LockStep:
    """Actions for all envs in one batch, the learner's due gradient steps (their logs to
    ``on_updates``) while the envs simulate, then the step's results. ``timing``, if given,
    gains the seconds of "act", "env" and "learn"."""
    perf = time.perf_counter
    t0 = perf()
    actions = agent.act_batch(obs)
    t1 = perf()
    collector.step_async(actions)
    t2 = perf()
    if isinstance(agent, D3QNAgent):
        updates = agent.update_pending()
        if on_updates is not None:
            on_updates(updates)
    t3 = perf()
    obs2, rewards, terminated, truncated, infos = collector.step_wait()
    t4 = perf()
    if timing is not None:
        timing["act"] += t1 - t0
        timing["env"] += (t2 - t1) + (t4 - t3)
        timing["learn"] += t3 - t2
    return LockStep(obs, actions, obs2, rewards, terminated, truncated, infos)


def feed(agent: Agent, transition: Transition, env: int = 0) -> Updates:
    """Give env ``env``'s transition to the learner: the D3QN stores it (its gradient steps
    come with the next ``step_envs``), the tabular agent learns from it at once (or, with
    ``n_step`` > 1, from the n-step targets it completes); the update logs."""
    if isinstance(agent, D3QNAgent):
        agent.observe(transition, env)
        return []
    return [agent.learn(transition, env)]
