"""Dueling Double DQN (D3QN) over a discrete action set (docs/design/agent.md#d3qn-agent, paper Eq. dueling, double).

Training loop contract (one control step)::

    a = agent.act(obs)                                   # epsilon-greedy, epsilon(train_steps)
    obs2, r, terminated, truncated = ...                 # env step; r with RewardParams(scale=0.01)
    logs = agent.learn(Transition(obs, a, r, obs2, terminated, truncated))

``learn`` = ``observe`` (store the transition) + ``update`` (one gradient step every
``train_freq`` observed transitions once ``learning_starts`` were stored, then a Polyak
update of the target network). Truncation by the time limit is stored as non-terminal, so
the target still bootstraps from ``obs2``; goal and collision are terminal.

A vectorised loop (several envs in lock-step) calls ``act_batch`` for all envs at once,
``observe`` for each transition in env order, and ``update_pending`` for the gradient steps
those transitions made due: the update-to-data ratio stays 1 / ``train_freq`` whatever the
number of envs. ``timing`` holds the seconds of each part of the updates (sample,
forward_backward, optimiser, target_update).
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.agents.n_step import N_STEP_RULE, NStepWindows, is_n_step
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.learning.agents.replay import ReplayBuffer, Transition
from d3dwa_bullet.limits import MAX_REPLAY_CAPACITY
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ActionSet
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT


@dataclass(frozen=True)
class D3QNConfig:
    """Hyper-parameters of the D3QN agent; saved beside every checkpoint."""

    gamma: float = 0.99
    """Discount factor per control step (0.1 s)."""
    lr: float = 5e-4
    """Adam learning rate."""
    batch_size: int = 64
    """Transitions per gradient step."""
    buffer_size: int = 100_000
    """Replay capacity, transitions."""
    learning_starts: int = 1_000
    """Transitions observed before the first gradient step."""
    train_freq: int = 1
    """One gradient step every this many observed transitions."""
    tau_soft: float = 0.005
    """Polyak coefficient of the target update after every gradient step (1 = hard copy)."""
    eps_start: float = 1.0
    """Exploration rate before any training step."""
    eps_end: float = 0.05
    """Asymptotic exploration rate."""
    eps_decay: float = 20_000.0
    """Time constant of the exponential epsilon decay, in training (gradient) steps."""
    grad_clip: float = 10.0
    """Max global L2 norm of the gradient."""
    huber_delta: float = 1.0
    """Huber loss threshold between its quadratic and linear parts."""
    hidden: tuple[int, ...] = (128, 128)
    """Widths of the shared MLP layers."""
    seed: int = 0
    """Seeds network init, exploration and replay sampling."""
    torch_threads: int = 1
    """Intra-op threads for torch (a 12-d MLP runs fastest on one; 0 leaves torch's default)."""
    n_step: int = 1
    """Rewards each stored transition sums before its target bootstraps; 1: the paper's
    one-step target. Beyond the paper, off by default (agents/n_step.py)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))
        checks: list[tuple[str, bool, str]] = [
            ("gamma", 0.0 < self.gamma < 1.0, "in (0, 1)"),
            ("lr", self.lr > 0, "> 0"),
            ("batch_size", self.batch_size >= 1, ">= 1"),
            (
                "buffer_size",
                self.buffer_size >= self.batch_size,
                f">= batch_size ({self.batch_size})",
            ),
            (
                "buffer_size",
                self.buffer_size <= MAX_REPLAY_CAPACITY.value,
                f"<= {MAX_REPLAY_CAPACITY.value} ({MAX_REPLAY_CAPACITY.why})",
            ),
            ("learning_starts", self.learning_starts >= 0, ">= 0"),
            ("train_freq", self.train_freq >= 1, ">= 1"),
            ("tau_soft", 0.0 < self.tau_soft <= 1.0, "in (0, 1]"),
            ("eps_start", 0.0 <= self.eps_start <= 1.0, "in [0, 1]"),
            (
                "eps_end",
                0.0 <= self.eps_end <= self.eps_start,
                f"in [0, eps_start ({self.eps_start})]",
            ),
            ("eps_decay", self.eps_decay > 0, "> 0"),
            ("grad_clip", self.grad_clip > 0, "> 0"),
            ("huber_delta", self.huber_delta > 0, "> 0"),
            ("hidden", bool(self.hidden) and min(self.hidden) >= 1, "non-empty positive widths"),
            ("torch_threads", self.torch_threads >= 0, ">= 0"),
            ("n_step", is_n_step(self.n_step), N_STEP_RULE),
        ]
        for name, ok, rule in checks:
            if not ok:
                raise ConfigError(f"D3QNConfig.{name} must be {rule}, got {getattr(self, name)!r}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready field dict."""
        out = asdict(self)
        out["hidden"] = list(self.hidden)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> D3QNConfig:
        """Inverse of ``to_dict``; ConfigError on unknown fields or invalid values."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"D3QNConfig: unknown field(s) {unknown}")
        kwargs = dict(data)
        if "hidden" in kwargs:
            kwargs["hidden"] = tuple(kwargs["hidden"])
        return cls(**kwargs)


def exponential_epsilon(step: int, start: float, end: float, decay: float) -> float:
    """end + (start - end) * exp(-step / decay): the exploration rate after ``step`` updates."""
    return end + (start - end) * math.exp(-step / decay)


def huber_loss(pred: torch.Tensor, target: torch.Tensor, delta: float = 1.0) -> torch.Tensor:
    """Mean Huber loss: 0.5 e^2 where |e| <= delta, else delta (|e| - 0.5 delta); e = pred - target."""
    return F.huber_loss(pred, target, reduction="mean", delta=delta)


@torch.no_grad()
def double_dqn_target(
    rewards: torch.Tensor,
    next_obs: torch.Tensor,
    terminated: torch.Tensor,
    online: Callable[[torch.Tensor], torch.Tensor],
    target: Callable[[torch.Tensor], torch.Tensor],
    gamma: float | torch.Tensor,
) -> torch.Tensor:
    """y = r + gamma (1 - d) Q_target(s', argmax_a Q_online(s', a)): (B,) float32.

    rewards, terminated: (B,) float32 (terminated in {0, 1}); next_obs: (B, obs_dim);
    gamma: a number, or (B,) float32 per transition (gamma^k of a k-step one).
    The online network selects the next action, the target network values it.
    """
    next_actions = online(next_obs).argmax(dim=1, keepdim=True)
    next_values = target(next_obs).gather(1, next_actions).squeeze(1)
    return rewards + gamma * (1.0 - terminated) * next_values


@torch.no_grad()
def polyak_update(target: nn.Module, online: nn.Module, tau: float) -> None:
    """In place: theta_target <- (1 - tau) theta_target + tau theta_online (buffers copied)."""
    if not 0.0 < tau <= 1.0:
        raise ConfigError(f"polyak_update: tau must be in (0, 1], got {tau!r}")
    # one fused call over all tensors instead of a Python loop of two ops each
    torch._foreach_lerp_(list(target.parameters()), list(online.parameters()), tau)
    for t, o in zip(target.buffers(), online.buffers(), strict=True):
        t.copy_(o)


@torch.no_grad()
def clip_grad_norm(parameters: Sequence[torch.Tensor], max_norm: float) -> torch.Tensor:
    """Scale the gradients in place so their global L2 norm is at most ``max_norm``; returns
    the norm before clipping (as ``torch.nn.utils.clip_grad_norm_``, with fewer checks)."""
    grads = [p.grad for p in parameters if p.grad is not None]
    norm = torch.linalg.vector_norm(torch.stack(torch._foreach_norm(grads)))
    torch._foreach_mul_(grads, torch.clamp(max_norm / (norm + 1e-6), max=1.0))
    return norm


class D3QNAgent:
    """D3QN with uniform replay, Huber loss, soft target updates and epsilon-greedy exploration.

    actions: the discrete action table (its size is the network's output width).
    obs_layout: names of the observation entries (its length is the input width).
    """

    method_family = "d3qn"

    def __init__(
        self,
        actions: ActionSet = ACTIONS_FULL,
        config: D3QNConfig = D3QNConfig(),
        obs_layout: Sequence[str] = OBSERVATION_LAYOUT,
    ) -> None:
        self.actions = actions
        self.config = config
        self.obs_layout = tuple(obs_layout)
        self.obs_dim = len(self.obs_layout)
        self.n_actions = actions.size
        if config.torch_threads:
            torch.set_num_threads(config.torch_threads)
        act_seed, replay_seed = np.random.SeedSequence(config.seed).spawn(2)
        self._rng = np.random.default_rng(act_seed)
        self._replay_seed = replay_seed
        self._replay: ReplayBuffer | None = None  # allocated on first observe (not for inference)
        self.n_step_windows = NStepWindows(config.n_step, config.gamma)
        """Each env's transitions waiting to be stored as n-step ones (none when n_step is 1)."""
        with torch.random.fork_rng(devices=[]):  # deterministic init, global RNG untouched
            torch.manual_seed(config.seed)
            self.online = DuelingQNetwork(self.obs_dim, self.n_actions, config.hidden)
        self.target = copy.deepcopy(self.online).requires_grad_(False)
        # Built on the first update: constructing a torch optimizer imports torch._dynamo
        # (~2 s), which an evaluation-only load should not pay.
        self._optimizer: torch.optim.Optimizer | None = None
        self._params = list(self.online.parameters())
        self.env_steps = 0
        """Transitions observed."""
        self.train_steps = 0
        """Gradient steps taken (advances epsilon)."""
        self.timing = {"sample": 0.0, "forward_backward": 0.0, "optimiser": 0.0,
                       "target_update": 0.0}  # fmt: skip
        """Seconds spent in each part of the gradient steps so far."""

    @property
    def replay(self) -> ReplayBuffer:
        if self._replay is None:
            self._replay = ReplayBuffer(self.config.buffer_size, self.obs_dim, self._replay_seed)
        return self._replay

    @property
    def optimizer(self) -> torch.optim.Optimizer:
        if self._optimizer is None:
            # fused: one kernel for every parameter's Adam step (the step is ~20 % of an update)
            self._optimizer = torch.optim.Adam(self._params, lr=self.config.lr, fused=True)
        return self._optimizer

    def epsilon(self, step: int | None = None) -> float:
        """Exploration rate after ``step`` training steps (default: the agent's own count)."""
        c = self.config
        return exponential_epsilon(
            self.train_steps if step is None else step, c.eps_start, c.eps_end, c.eps_decay
        )

    def q_values(self, obs: np.ndarray) -> np.ndarray:
        """Online Q-values: obs (obs_dim,) or (B, obs_dim) -> (n_actions,) or (B, n_actions)."""
        x = torch.as_tensor(np.asarray(obs, dtype=np.float32))
        with torch.inference_mode():
            return self.online(x).numpy()

    def act(self, obs: np.ndarray, greedy: bool = False) -> int:
        """Action index for one observation (obs_dim,): epsilon-greedy unless ``greedy``."""
        if not greedy and self._rng.random() < self.epsilon():
            return int(self._rng.integers(self.n_actions))
        x = torch.as_tensor(np.asarray(obs, dtype=np.float32)).unsqueeze(0)
        with torch.inference_mode():
            return int(self.online(x).argmax(dim=1).item())

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        """Epsilon-greedy actions for a batch (n, obs_dim): the exploration draws are made
        env by env in order, exactly as n calls of ``act``; the greedy ones share one
        forward pass. Returns (n,) int64."""
        eps = self.epsilon()
        n = len(obs)
        out = np.empty(n, dtype=np.int64)
        greedy = np.zeros(n, dtype=bool)
        for i in range(n):
            if self._rng.random() < eps:
                out[i] = self._rng.integers(self.n_actions)
            else:
                greedy[i] = True
        if greedy.any():
            x = torch.as_tensor(np.asarray(obs, dtype=np.float32)[greedy])
            with torch.inference_mode():
                out[greedy] = self.online(x).argmax(dim=1).numpy()
        return out

    def observe(self, transition: Transition, env: int = 0) -> None:
        """Store one transition of env ``env`` (truncation is kept non-terminal) through the
        env's n-step window: with ``n_step`` 1 it is stored at once with discount gamma,
        else it waits and the n-step ones it completes are stored (agents/n_step.py).
        ``env_steps`` counts the transitions observed."""
        if not 0 <= transition.action < self.n_actions:
            raise ConfigError(f"D3QNAgent.observe: action {transition.action!r} out of range")
        for name in ("obs", "next_obs"):
            x = np.asarray(getattr(transition, name))
            if x.shape != (self.obs_dim,) or not np.all(np.isfinite(x)):
                raise ValueError(
                    f"D3QNAgent.observe: {name} must be finite with shape ({self.obs_dim},), got {x!r}"
                )
        for stored, discount in self.n_step_windows.push(transition, env):
            self.replay.add(stored, discount)
        self.env_steps += 1

    def update(self) -> dict[str, float]:
        """One gradient step + target update if due (see module docstring), else {}.

        Returns TensorBoard-style scalars: losses/td_loss, losses/q_values (mean Q of the
        taken actions), losses/grad_norm (before clipping), charts/epsilon.
        """
        if self.pending_updates() == 0:
            return {}
        c = self.config
        timing, t0 = self.timing, time.perf_counter()
        batch = self.replay.sample(c.batch_size)
        obs = torch.from_numpy(batch.obs)
        actions = torch.from_numpy(batch.actions)
        rewards = torch.from_numpy(batch.rewards)
        next_obs = torch.from_numpy(batch.next_obs)
        terminated = torch.from_numpy(batch.terminated)
        discount = torch.from_numpy(batch.discounts)  # gamma^k of each k-step transition
        t1 = time.perf_counter()

        y = double_dqn_target(rewards, next_obs, terminated, self.online, self.target, discount)
        q = self.online(obs).gather(1, actions.unsqueeze(1)).squeeze(1)
        loss = huber_loss(q, y, c.huber_delta)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        t2 = time.perf_counter()
        grad_norm = clip_grad_norm(self._params, c.grad_clip)
        self.optimizer.step()
        t3 = time.perf_counter()
        polyak_update(self.target, self.online, c.tau_soft)
        self.train_steps += 1
        td_loss, q_mean, norm = torch.stack((loss.detach(), q.detach().mean(), grad_norm)).tolist()
        t4 = time.perf_counter()
        timing["sample"] += t1 - t0
        timing["forward_backward"] += t2 - t1
        timing["optimiser"] += t3 - t2
        timing["target_update"] += t4 - t3
        return {
            "losses/td_loss": td_loss,
            "losses/q_values": q_mean,
            "losses/grad_norm": norm,
            "charts/epsilon": self.epsilon(),
        }

    def pending_updates(self) -> int:
        """Gradient steps due and not yet taken: one for every multiple of ``train_freq``
        among the transitions observed, from the first at which ``learning_starts`` were
        stored and a batch can be drawn."""
        c = self.config
        first = max(c.learning_starts, c.batch_size, 1)
        if self.env_steps < first or self._replay is None or len(self._replay) == 0:
            return 0  # (n-step transitions are stored up to n - 1 observations late)
        slots = self.env_steps // c.train_freq - (first - 1) // c.train_freq
        return max(0, slots - self.train_steps)

    def update_pending(self) -> list[dict[str, float]]:
        """Take every gradient step due (``pending_updates``); their logs, in order."""
        return [self.update() for _ in range(self.pending_updates())]

    def learn(self, transition: Transition) -> dict[str, float]:
        """``observe`` then ``update``: the one call a training loop makes per control step."""
        self.observe(transition)
        return self.update()

    def state_dict(self) -> dict[str, torch.Tensor]:
        """The online network's tensors (what a checkpoint stores)."""
        return self.online.state_dict()

    def load_state_dict(self, state: Mapping[str, torch.Tensor]) -> None:
        """Load online weights and copy them to the target network."""
        self.online.load_state_dict(state)
        self.target.load_state_dict(self.online.state_dict())
