"""n-step transitions (D3QNConfig.n_step, agents/n_step.py): what is stored, per env.

A reference written from the definition (for each step t of an episode, the rewards of
steps t .. min(t+n, end) - 1 discounted, the observation after the last of them, that
step's terminal flag and gamma^k) is compared with what the agent stores, through the
trainer's collection path with two interleaved envs on the chain MDP.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.n_step import MAX_N_STEP, NStepWindows
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.training.collector import Collector, env_seeds
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.learning.training.lock_step import feed, step_envs
from d3dwa_bullet.planning.actions import ActionSet
from tests.support.chain_mdp import ChainMDP


def _t(k: int, reward: float, terminated: bool = False, truncated: bool = False) -> Transition:
    obs = np.full(3, k, dtype=np.float32)
    return Transition(obs, k, reward, obs + 1, terminated, truncated)


def test_a_full_window_leaves_as_one_discounted_transition() -> None:
    w = NStepWindows(3, 0.5)
    assert w.push(_t(0, 1.0)) == [] and w.push(_t(1, 2.0)) == []
    [(first, discount)] = w.push(_t(2, 4.0))
    assert first.action == 0 and first.reward == pytest.approx(1.0 + 0.5 * 2.0 + 0.25 * 4.0)
    assert first.obs[0] == 0 and first.next_obs[0] == 3  # the observation after step 2
    assert discount == 0.125 and not first.terminated
    [(second, _)] = w.push(_t(3, 8.0))
    assert second.action == 1 and second.reward == pytest.approx(2.0 + 2.0 + 2.0)
    assert w.pending() == 2


@pytest.mark.parametrize("end", ["terminated", "truncated"])
def test_an_episode_end_flushes_every_start_with_the_rewards_left(end: str) -> None:
    w = NStepWindows(3, 0.5)
    w.push(_t(0, 1.0))
    out = w.push(_t(1, 2.0, **{end: True}))
    assert [(t.action, t.reward, d) for t, d in out] == [(0, 2.0, 0.25), (1, 2.0, 0.5)]
    # a goal or collision stays terminal, a time limit stays a bootstrap
    assert all(t.terminated == (end == "terminated") for t, _ in out)
    assert all(t.next_obs[0] == 2 for t, _ in out)
    assert w.pending() == 0


def test_the_envs_windows_do_not_mix() -> None:
    w = NStepWindows(2, 0.9)
    assert w.push(_t(0, 1.0), env=0) == [] and w.push(_t(10, 5.0), env=1) == []
    [(a, _)] = w.push(_t(1, 1.0), env=0)
    [(b, _)] = w.push(_t(11, 5.0), env=1)
    assert (a.action, b.action) == (0, 10)
    assert a.reward == pytest.approx(1.9) and b.reward == pytest.approx(9.5)


def test_the_windows_round_trip_through_json() -> None:
    rng = np.random.default_rng(0)
    steps = [Transition(rng.random(4).astype(np.float32), i, float(rng.random()),
                        rng.random(4).astype(np.float32), False) for i in range(5)]  # fmt: skip
    a = NStepWindows(4, 0.9)
    for i, t in enumerate(steps[:3]):
        a.push(t, env=i % 2)
    b = NStepWindows(4, 0.9)
    b.load_state(json.loads(json.dumps(a.state())), "test")
    for i, t in enumerate(steps[3:], start=3):
        out_a, out_b = a.push(t, env=i % 2), b.push(t, env=i % 2)
        assert len(out_a) == len(out_b)
        for (ta, da), (tb, db) in zip(out_a, out_b, strict=True):
            assert da == db and ta.reward == tb.reward and ta.action == tb.action
            assert np.array_equal(ta.obs, tb.obs) and np.array_equal(ta.next_obs, tb.next_obs)
    with pytest.raises(CheckpointError, match="n-step windows"):
        NStepWindows(4, 0.9).load_state({"0": [[1, 2]]}, "test")


@pytest.mark.parametrize("bad", [0, MAX_N_STEP + 1, 2.5, True])
def test_n_step_out_of_range_is_a_config_error(bad: int) -> None:
    with pytest.raises(ConfigError, match="n_step"):
        D3QNConfig(n_step=bad)


def _reference(episodes: list[list[Transition]], n: int, gamma: float) -> list[tuple]:
    rows = []
    for ep in episodes:
        for t in range(len(ep)):
            part = ep[t : t + n]
            ret = sum(gamma**k * s.reward for k, s in enumerate(part))
            last = part[-1]
            done = last.terminated or last.truncated
            if len(part) < n and not done:
                continue  # the episode in progress at the end: still waiting
            rows.append((tuple(ep[t].obs), ep[t].action, round(ret, 5),
                         tuple(last.next_obs), float(last.terminated),
                         round(gamma ** len(part), 5)))  # fmt: skip
    return sorted(rows)


def test_two_interleaved_envs_store_the_reference_n_step_transitions() -> None:
    n, gamma, steps = 3, 0.9, 200
    agent_cfg = D3QNConfig(hidden=(8,), batch_size=8, buffer_size=1000, learning_starts=50,
                           gamma=gamma, n_step=n, eps_start=1.0, eps_end=1.0)  # fmt: skip
    config = TrainConfig(method="d3dwa", total_steps=steps, n_envs=2, vector="sync",
                         agent=agent_cfg, eval_every=0, keep="final")  # fmt: skip
    mdp = ChainMDP()
    layout = tuple(f"state_{i}" for i in range(mdp.n_states))
    actions = ActionSet(weights=(1.0,), horizons=(2.0, 3.0))
    agent = D3QNAgent(actions, config.agent, layout)  # type: ignore[arg-type]
    collector = Collector(config, env_fn=ChainMDP)
    episodes: list[list[list[Transition]]] = [[[]], [[]]]
    try:
        obs = collector.reset_all(env_seeds(0, 2), None)
        while agent.env_steps < steps:
            step = step_envs(agent, collector, obs)
            for i in range(2):
                t = step.transition(i)
                feed(agent, t, i)
                episodes[i][-1].append(t)
                if t.terminated or t.truncated:
                    episodes[i].append([])
            obs = step.next_obs
            if step.done.any():
                obs = collector.reset_some(step.done, None)
    finally:
        collector.close()
    r = agent.replay
    k = len(r)
    stored = sorted(
        (tuple(r._obs[i]), int(r._actions[i]), round(float(r._rewards[i]), 5),
         tuple(r._next_obs[i]), float(r._terminated[i]), round(float(r._discounts[i]), 5))
        for i in range(k)
    )  # fmt: skip
    expected = _reference(episodes[0] + episodes[1], n, gamma)
    assert stored == expected
    assert k + agent.n_step_windows.pending() == agent.env_steps == steps
    assert any(row[4] == 1.0 for row in stored) and any(row[5] > gamma**n + 1e-6 for row in stored)
