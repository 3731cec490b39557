"""Uniform experience replay with its own seeded Generator."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from d3dwa_bullet import limits
from d3dwa_bullet.errors import ConfigError


class Transition(NamedTuple):
    """One environment step as the agents see it.

    ``terminated`` (goal or collision) stops bootstrapping; ``truncated`` (the time limit)
    does not, so the buffer does not store it. ``next_obs`` is the observation reached by the
    step, even when the episode then ends (never the next episode's first observation).
    """

    obs: np.ndarray
    action: int
    reward: float
    next_obs: np.ndarray
    terminated: bool
    truncated: bool = False


class ReplayBatch(NamedTuple):
    """A sampled minibatch: obs, next_obs (B, obs_dim) float32; actions (B,) int64;
    rewards (B,) float32; terminated (B,) float32 in {0, 1}; discounts (B,) float32, the
    discount of each bootstrap (gamma^k for a k-step transition, agents/n_step.py)."""

    obs: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    next_obs: np.ndarray
    terminated: np.ndarray
    discounts: np.ndarray


def replay_bytes(capacity: int, obs_dim: int) -> int:
    """Bytes a ReplayBuffer of ``capacity`` transitions allocates: obs and next_obs
    float32, action int64, reward, terminated and discount float32."""
    return int(capacity) * (2 * 4 * int(obs_dim) + 8 + 4 + 4 + 4)


def check_replay_memory(capacity: int, obs_dim: int, option: str = "buffer_size") -> None:
    """ConfigError naming ``option`` when ``capacity`` is over ``MAX_REPLAY_CAPACITY`` or
    the buffer would take more than ``REPLAY_MEMORY_FRACTION`` of the memory available now
    (:mod:`d3dwa_bullet.limits`)."""
    limits.MAX_REPLAY_CAPACITY.check(option, capacity, "transitions")
    need, available = replay_bytes(capacity, obs_dim), limits.available_memory()
    if need > limits.REPLAY_MEMORY_FRACTION * available:
        raise ConfigError(
            f"{option}: {capacity} transitions need {need / 2**30:.2f} GiB, over "
            f"{limits.REPLAY_MEMORY_FRACTION:.0%} of the {available / 2**30:.2f} GiB of memory "
            "available (the replay buffer is allocated whole; a smaller one, or more memory)"
        )


class ReplayBuffer:
    """A ring buffer of ``capacity`` transitions, sampled uniformly with replacement."""

    def __init__(self, capacity: int, obs_dim: int, seed: int | np.random.SeedSequence = 0) -> None:
        if capacity < 1 or obs_dim < 1:
            raise ConfigError(
                f"ReplayBuffer: capacity and obs_dim must be >= 1, got {capacity}, {obs_dim}"
            )
        check_replay_memory(capacity, obs_dim)
        self.capacity = int(capacity)
        self.obs_dim = int(obs_dim)
        self._rng = np.random.default_rng(seed)
        self._obs = np.zeros((self.capacity, self.obs_dim), dtype=np.float32)
        self._next_obs = np.zeros((self.capacity, self.obs_dim), dtype=np.float32)
        self._actions = np.zeros(self.capacity, dtype=np.int64)
        self._rewards = np.zeros(self.capacity, dtype=np.float32)
        self._terminated = np.zeros(self.capacity, dtype=np.float32)
        self._discounts = np.zeros(self.capacity, dtype=np.float32)
        self._pos = 0
        self._size = 0

    def __len__(self) -> int:
        return self._size

    def add(self, transition: Transition, discount: float) -> None:
        """Store one transition, overwriting the oldest once full; ``discount``: that of its
        bootstrap (gamma for a one-step transition)."""
        i = self._pos
        self._obs[i] = transition.obs
        self._next_obs[i] = transition.next_obs
        self._actions[i] = transition.action
        self._rewards[i] = transition.reward
        self._terminated[i] = float(bool(transition.terminated))
        self._discounts[i] = discount
        self._pos = (i + 1) % self.capacity
        self._size = min(self._size + 1, self.capacity)

    def sample(self, batch_size: int) -> ReplayBatch:
        """``batch_size`` transitions drawn uniformly (with replacement) from those stored."""
        if self._size == 0:
            raise RuntimeError("ReplayBuffer.sample: the buffer is empty")
        idx = self._rng.integers(0, self._size, size=batch_size)
        return ReplayBatch(
            self._obs[idx],
            self._actions[idx],
            self._rewards[idx],
            self._next_obs[idx],
            self._terminated[idx],
            self._discounts[idx],
        )
