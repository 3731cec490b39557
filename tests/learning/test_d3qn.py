"""D3QN maths pinned by hand, plus a tiny chain environment it must solve."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.agents.d3qn import (
    D3QNAgent,
    D3QNConfig,
    double_dqn_target,
    huber_loss,
    polyak_update,
)
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.learning.agents.replay import ReplayBuffer, Transition
from d3dwa_bullet.planning.actions import ActionSet

TWO_ACTIONS = ActionSet((1.0,), (1.0, 2.0))  # one weight triple x two horizons = 2 actions


def _hand_network() -> DuelingQNetwork:
    net = DuelingQNetwork(2, 3, hidden=(2,))
    with torch.no_grad():
        net.body[0].weight.copy_(torch.eye(2))
        net.body[0].bias.zero_()
        net.value.weight.copy_(torch.tensor([[1.0, 1.0]]))
        net.value.bias.copy_(torch.tensor([0.5]))
        net.advantage.weight.copy_(torch.tensor([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
        net.advantage.bias.copy_(torch.tensor([0.0, 0.0, -3.0]))
    return net


@pytest.mark.parametrize(
    ("obs", "v", "adv"),
    [
        ([1.0, 2.0], 3.5, [1.0, 2.0, 0.0]),
        ([-1.0, 2.0], 2.5, [0.0, 2.0, -1.0]),  # ReLU zeroes the first feature
    ],
)
def test_dueling_aggregation(obs: list[float], v: float, adv: list[float]) -> None:
    net = _hand_network()
    x = torch.tensor([obs])
    value, advantage = net.streams(x)
    assert value.item() == pytest.approx(v)
    assert advantage[0].tolist() == pytest.approx(adv)
    expected = [v + a - sum(adv) / 3 for a in adv]
    q = net(x)
    assert q.shape == (1, 3)
    assert q[0].tolist() == pytest.approx(expected)
    assert q.mean().item() == pytest.approx(v)  # mean_a Q = V by construction


def test_network_rejects_bad_shapes() -> None:
    with pytest.raises(ConfigError, match="hidden"):
        DuelingQNetwork(12, 100, hidden=())


class _Fixed(torch.nn.Module):
    """A 'network' returning fixed Q-values per batch row, whatever the input."""

    def __init__(self, q: list[list[float]]) -> None:
        super().__init__()
        self.q = torch.tensor(q)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.q


def test_double_dqn_target_selects_online_values_target() -> None:
    online = _Fixed([[1.0, 5.0, 2.0], [3.0, 0.0, 1.0], [0.0, 0.0, 9.0], [0.0, 4.0, 0.0]])
    target = _Fixed([[10.0, 20.0, 30.0], [40.0, 50.0, 60.0], [7.0, 8.0, 9.0], [1.0, -6.0, 1.0]])
    rewards = torch.tensor([1.0, 2.0, 3.0, 0.5])
    terminated = torch.tensor([0.0, 0.0, 1.0, 0.0])
    y = double_dqn_target(rewards, torch.zeros(4, 2), terminated, online, target, gamma=0.5)
    # argmax online = [1, 0, 2, 1] -> target values [20, 40, (terminal), -6]; the target's own
    # max would have given 30, 60, 1 instead.
    assert y.tolist() == [11.0, 22.0, 3.0, -2.5]


@pytest.mark.parametrize(
    ("terminated", "truncated", "stored"),
    [(True, False, 1.0), (False, True, 0.0), (False, False, 0.0)],
)
def test_truncation_is_stored_non_terminal(
    terminated: bool, truncated: bool, stored: float
) -> None:
    buf = ReplayBuffer(4, 2, seed=0)
    buf.add(Transition(np.zeros(2), 1, 0.5, np.ones(2), terminated, truncated), 0.5)
    batch = buf.sample(3)
    assert batch.terminated.tolist() == [stored] * 3
    assert batch.actions.dtype == np.int64 and batch.obs.dtype == np.float32
    # and a non-terminal row bootstraps in the target
    q = _Fixed([[2.0, 4.0]] * 3)
    y = double_dqn_target(
        torch.from_numpy(batch.rewards),
        torch.from_numpy(batch.next_obs),
        torch.from_numpy(batch.terminated),
        q,
        q,
        0.5,
    )
    assert y.tolist() == [0.5 + (1.0 - stored) * 2.0] * 3


def test_replay_ring_and_seeded_sampling() -> None:
    a, b = ReplayBuffer(3, 1, seed=7), ReplayBuffer(3, 1, seed=7)
    for i in range(5):
        for buf in (a, b):
            buf.add(Transition(np.array([i]), 0, float(i), np.array([i + 1]), False), 0.9)
    assert len(a) == 3
    sa, sb = a.sample(50), b.sample(50)
    assert np.array_equal(sa.rewards, sb.rewards)
    assert set(sa.rewards.tolist()) == {2.0, 3.0, 4.0}  # the two oldest were overwritten
    assert np.array_equal(sa.next_obs[:, 0], sa.obs[:, 0] + 1)


def test_huber_loss_by_hand() -> None:
    pred = torch.zeros(3)
    target = torch.tensor([0.5, 2.0, -3.0])
    # 0.5 * 0.25, 1 * (2 - 0.5), 1 * (3 - 0.5)
    assert huber_loss(pred, target, 1.0).item() == pytest.approx((0.125 + 1.5 + 2.5) / 3)
    assert huber_loss(pred, target, 4.0).item() == pytest.approx((0.125 + 2.0 + 4.5) / 3)


@pytest.mark.parametrize("tau", [0.25, 0.5, 1.0])
def test_polyak_update_exact(tau: float) -> None:
    target, online = DuelingQNetwork(3, 2, (4,)), DuelingQNetwork(3, 2, (4,))
    with torch.no_grad():
        for p in target.parameters():
            p.fill_(1.0)
        for p in online.parameters():
            p.fill_(3.0)
    polyak_update(target, online, tau)
    for p in target.parameters():
        assert torch.equal(p, torch.full_like(p, (1.0 - tau) * 1.0 + tau * 3.0))
    for p in online.parameters():
        assert torch.equal(p, torch.full_like(p, 3.0))


@pytest.mark.parametrize("tau", [0.0, -0.1, 1.5])
def test_polyak_rejects_bad_tau(tau: float) -> None:
    net = DuelingQNetwork(3, 2, (4,))
    with pytest.raises(ConfigError, match="tau"):
        polyak_update(net, net, tau)


def test_epsilon_formula() -> None:
    agent = D3QNAgent(
        TWO_ACTIONS, D3QNConfig(eps_start=1.0, eps_end=0.1, eps_decay=100.0), ("x", "y")
    )
    assert agent.epsilon(0) == 1.0
    assert agent.epsilon(100) == pytest.approx(0.1 + 0.9 / math.e)
    assert agent.epsilon(10**6) == pytest.approx(0.1)


def test_epsilon_advances_with_training_steps_only() -> None:
    cfg = D3QNConfig(
        batch_size=4, buffer_size=64, learning_starts=20, train_freq=2, eps_decay=10.0, hidden=(8,)
    )
    agent = D3QNAgent(TWO_ACTIONS, cfg, ("x", "y"))
    rng = np.random.default_rng(0)
    for step in range(1, 31):
        obs = rng.random(2)
        a = agent.act(obs)
        logs = agent.learn(Transition(obs, a, 0.0, rng.random(2), False))
        assert agent.update() == {}  # a second call in the same step never trains twice
        expected_updates = (
            max(0, (step - cfg.learning_starts) // cfg.train_freq + 1)
            if step >= cfg.learning_starts
            else 0
        )
        assert agent.env_steps == step
        assert agent.train_steps == expected_updates
        assert agent.epsilon() == cfg.eps_end + (cfg.eps_start - cfg.eps_end) * math.exp(
            -expected_updates / cfg.eps_decay
        )
        if logs:
            assert set(logs) == {
                "losses/td_loss",
                "losses/q_values",
                "losses/grad_norm",
                "charts/epsilon",
            }
            assert step >= cfg.learning_starts and step % cfg.train_freq == 0
    assert agent.train_steps == 6


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("buffer_size", 10),
        ("gamma", 1.5),
        ("lr", 0.0),
        ("train_freq", 0),
        ("tau_soft", 0.0),
        ("eps_end", 1.1),
        ("eps_decay", 0.0),
        ("grad_clip", -1.0),
        ("hidden", ()),
        ("learning_starts", -1),
    ],
)
def test_config_validation_names_field(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=f"D3QNConfig.{field}"):
        D3QNConfig(batch_size=32, **{field: value})


def test_config_dict_round_trip() -> None:
    cfg = D3QNConfig(hidden=(64, 32), seed=3)
    assert D3QNConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ConfigError, match="unknown field"):
        D3QNConfig.from_dict({**cfg.to_dict(), "momentum": 0.9})


def test_observe_rejects_bad_input() -> None:
    agent = D3QNAgent(TWO_ACTIONS, D3QNConfig(hidden=(8,)), ("x", "y"))
    with pytest.raises(ConfigError, match="action 2"):
        agent.observe(Transition(np.zeros(2), 2, 0.0, np.zeros(2), False))
    with pytest.raises(ValueError, match="shape"):
        agent.observe(Transition(np.zeros(3), 0, 0.0, np.zeros(2), False))
    with pytest.raises(ValueError, match="finite"):
        agent.observe(Transition(np.zeros(2), 0, 0.0, np.array([0.0, np.nan]), False))


def test_construction_is_seeded_and_leaves_global_rng_alone() -> None:
    torch.manual_seed(123)
    before = torch.rand(1)
    torch.manual_seed(123)
    a = D3QNAgent(TWO_ACTIONS, D3QNConfig(seed=5, hidden=(8,)), ("x", "y"))
    after = torch.rand(1)
    b = D3QNAgent(TWO_ACTIONS, D3QNConfig(seed=5, hidden=(8,)), ("x", "y"))
    assert torch.equal(before, after)
    for k, v in a.state_dict().items():
        assert torch.equal(v, b.state_dict()[k])
    for k, v in a.online.state_dict().items():
        assert torch.equal(v, a.target.state_dict()[k])


class ChainEnv:
    """States 0..3 (one-hot). Action 1 steps right (+1 and terminal from state 3); action 0
    bails out with +0.1 and terminates. With gamma = 0.9 going right is optimal everywhere:
    Q*(s, right) = 0.9 ** (3 - s), Q*(s, bail) = 0.1."""

    n = 4

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.s = 0

    def obs(self) -> np.ndarray:
        return np.eye(self.n)[self.s]

    def reset(self) -> np.ndarray:
        self.s = int(self.rng.integers(self.n))
        return self.obs()

    def step(self, a: int) -> tuple[np.ndarray, float, bool]:
        if a == 0:
            return self.obs(), 0.1, True
        if self.s == self.n - 1:
            return self.obs(), 1.0, True
        self.s += 1
        return self.obs(), 0.0, False


def _train_chain(seed: int, steps: int) -> D3QNAgent:
    cfg = D3QNConfig(
        gamma=0.9,
        lr=5e-3,
        batch_size=16,
        buffer_size=5_000,
        learning_starts=50,
        tau_soft=0.1,
        eps_decay=150.0,
        hidden=(32,),
        seed=seed,
    )
    agent = D3QNAgent(TWO_ACTIONS, cfg, tuple(f"s{i}" for i in range(ChainEnv.n)))
    env = ChainEnv(seed)
    obs = env.reset()
    for _ in range(steps):
        a = agent.act(obs)
        obs2, r, done = env.step(a)
        agent.learn(Transition(obs, a, r, obs2, done))
        obs = env.reset() if done else obs2
    return agent


def test_learns_chain() -> None:
    torch.manual_seed(0)
    agent = _train_chain(seed=0, steps=600)
    q = agent.q_values(np.eye(ChainEnv.n))
    assert [agent.act(o, greedy=True) for o in np.eye(ChainEnv.n)] == [1] * ChainEnv.n
    assert q[:, 1] == pytest.approx([0.9**3, 0.9**2, 0.9, 1.0], abs=0.05)


def test_training_is_deterministic() -> None:
    a, b = _train_chain(seed=1, steps=150), _train_chain(seed=1, steps=150)
    assert a.train_steps == b.train_steps > 0
    for k, v in a.state_dict().items():
        assert torch.equal(v, b.state_dict()[k])
