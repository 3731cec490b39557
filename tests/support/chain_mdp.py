"""A chain MDP whose optimal Q is known in closed form: the learner's correctness test.

States 0 .. n-1 on a line; state n-1 is the goal. Action 0 moves left (state 0 stays put),
every other action moves right (``n_actions - 1`` identical copies of "right": with many,
the max over near-identical actions that issue 29 suspects of overestimation). A step
costs ``step_penalty``; the step that enters the goal earns ``goal_reward`` instead and
terminates. Episodes start at a uniformly drawn non-goal state and are *truncated* after
``time_limit`` steps, often enough that a learner treating truncation as terminal is
wrong by far more than the test's tolerance. ``reward_noise`` adds zero-mean Gaussian noise
of that standard deviation to every reward (Q* is unchanged). The observation is the state's one-hot
vector, float32 (n,).

With discount gamma, going right always is optimal; from d steps before the goal
(d = n-1-s)::

    V*(d) = gamma^(d-1) goal_reward - step_penalty (1 - gamma^(d-1)) / (1 - gamma)
    Q*(s, right) = V*(s),   Q*(s, left) = -step_penalty + gamma V*(max(s-1, 0))

the infinite-horizon values: the time limit is not part of the task.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

LEFT = 0
"""The one action that moves left; all the others move right."""


class ChainMDP(gymnasium.Env):
    """The chain of the module docstring."""

    def __init__(
        self,
        n_states: int = 5,
        n_actions: int = 2,
        time_limit: int = 4,
        step_penalty: float = 0.01,
        goal_reward: float = 1.0,
        reward_noise: float = 0.0,
    ) -> None:
        if n_states < 2 or n_actions < 2 or time_limit < 1:
            raise ValueError(f"ChainMDP: {n_states=}, {n_actions=}, {time_limit=} too small")
        self.n_states = n_states
        self.time_limit = time_limit
        self.step_penalty = step_penalty
        self.goal_reward = goal_reward
        self.reward_noise = reward_noise
        self.observation_space = spaces.Box(0.0, 1.0, (n_states,), np.float32)
        self.action_space = spaces.Discrete(n_actions)
        self.state = 0
        self.t = 0

    def _obs(self) -> np.ndarray:
        obs = np.zeros(self.n_states, dtype=np.float32)
        obs[self.state] = 1.0
        return obs

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.state = int(self.np_random.integers(self.n_states - 1))
        self.t = 0
        return self._obs(), {"state": self.state}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        a = int(action)
        if not 0 <= a < self.action_space.n:
            raise ValueError(f"ChainMDP.step: action {action!r} out of range")
        self.state = max(self.state - 1, 0) if a == LEFT else self.state + 1
        self.t += 1
        terminated = self.state == self.n_states - 1
        reward = self.goal_reward if terminated else -self.step_penalty
        if self.reward_noise:
            reward += float(self.np_random.normal(0.0, self.reward_noise))
        truncated = not terminated and self.t >= self.time_limit
        return self._obs(), reward, terminated, truncated, {"state": self.state}

    def optimal_values(self, gamma: float) -> np.ndarray:
        """V*(s) of the non-goal states, (n-1,) float64."""
        d = np.arange(self.n_states - 1, 0, -1, dtype=np.float64)  # steps to the goal
        g = gamma ** (d - 1)
        return g * self.goal_reward - self.step_penalty * (1.0 - g) / (1.0 - gamma)

    def optimal_q(self, gamma: float) -> np.ndarray:
        """Q*(s, a) of the non-goal states, (n-1, n_actions) float64."""
        v = self.optimal_values(gamma)
        left = -self.step_penalty + gamma * v[np.maximum(np.arange(len(v)) - 1, 0)]
        q = np.repeat(v[:, None], self.action_space.n, axis=1)
        q[:, LEFT] = left
        return q

    def state_observations(self) -> np.ndarray:
        """The one-hot observations of the non-goal states, (n-1, n) float32."""
        return np.eye(self.n_states, dtype=np.float32)[:-1]
