"""DQDWA: the hand-designed discretisation and the tabular Q update, by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.agents.dqdwa import Discretisation, DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.planning.actions import ACTIONS_WEIGHTS_ONLY

D_MAX = 3.5
DISC = Discretisation()


def make_obs(bearing_deg: float, sectors_m: dict[int, float] | None = None) -> np.ndarray:
    """A 12-d observation: goal 3 m away at ``bearing_deg``, at rest, sector ranges in metres
    (sectors 0..7 run right to left; unlisted sectors see nothing)."""
    ranges = np.full(8, D_MAX)
    for k, r in (sectors_m or {}).items():
        ranges[k] = r
    return np.concatenate(([0.5, bearing_deg / 180.0, 0.0, 0.0], ranges / D_MAX))


@pytest.mark.parametrize(
    ("bearing", "sectors", "expected"),
    [
        # open space, goal ahead: nothing seen -> far, ties prefer front, no congestion
        (0.0, {}, (2, 2, 1, 0)),
        # goal hard right, one close obstacle on the right
        (-90.0, {0: 0.3}, (0, 0, 0, 0)),
        (-40.0, {2: 0.3, 3: 0.4}, (1, 0, 0, 1)),
        # goal front-left, obstacles on the left at 0.8-0.9 m: mid, left, 3 sectors < 1 m
        (30.0, {5: 0.9, 6: 0.8, 7: 0.9}, (3, 1, 2, 1)),
        # goal behind-left, crowded all round, nearest straight ahead
        (170.0, {k: 0.6 for k in range(8)} | {3: 0.55}, (4, 1, 1, 2)),
        # a far obstacle does not count towards congestion
        (10.0, {4: 1.5, 5: 2.0}, (2, 2, 1, 0)),
        (-10.0, {1: 1.1, 7: 1.1}, (2, 1, 0, 0)),  # right/left tie -> right; 1.1 m is not congested
        (179.0, {6: 0.49}, (4, 0, 2, 0)),
    ],
)
def test_discretisation_bins(
    bearing: float, sectors: dict[int, float], expected: tuple[int, ...]
) -> None:
    obs = make_obs(bearing, sectors)
    assert DISC.bins(obs) == expected
    assert DISC.state_index(obs) == int(np.ravel_multi_index(expected, (5, 3, 3, 3)))


def test_table_shape_and_labels() -> None:
    assert DISC.shape == (5, 3, 3, 3)
    assert DISC.n_states == 135
    agent = DQDWAAgent()
    assert agent.table.shape == (135, 25)
    assert agent.actions == ACTIONS_WEIGHTS_ONLY
    assert (
        DISC.describe(DISC.state_index(make_obs(0.0)))
        == "bearing 2/5, distance 2/3, front, congestion 0/3"
    )
    indices = {
        DISC.state_index(make_obs(b, {k: r}))
        for b in (-100, -30, 0, 30, 100)
        for k in range(8)
        for r in (0.3, 0.8, 3.0)
    }
    assert indices <= set(range(135))


@pytest.mark.parametrize("bad", [np.zeros(11), np.full(12, np.nan)])
def test_bad_observation(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="shape"):
        DISC.bins(bad)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"distance_edges": (1.2, 0.5)}, "distance_edges"),
        ({"bearing_edges": ()}, "bearing_edges"),
        ({"front_half_angle": math.radians(5.0)}, "covers no sector"),
        ({"congestion_range": 0.0}, "congestion_range"),
    ],
)
def test_discretisation_validation(kwargs: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        Discretisation(**kwargs)


def test_config_round_trip_and_validation() -> None:
    cfg = DQDWAConfig(alpha=0.2, discretisation=Discretisation(distance_edges=(0.4, 1.0, 2.0)))
    assert DQDWAConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ConfigError, match="DQDWAConfig.alpha"):
        DQDWAConfig(alpha=0.0)
    with pytest.raises(ConfigError, match="unknown field"):
        DQDWAConfig.from_dict({"beta": 1})


@pytest.mark.parametrize(
    ("terminated", "expected_td"), [(False, 2.0 + 0.5 * 3.0 - 1.0), (True, 2.0 - 1.0)]
)
def test_q_update_by_hand(terminated: bool, expected_td: float) -> None:
    agent = DQDWAAgent(config=DQDWAConfig(alpha=0.5, gamma=0.5))
    s, a, s2 = 7, 4, 11
    agent.table[s, a] = 1.0
    agent.table[s2, [0, 3, 9]] = [1.0, 3.0, 2.0]
    before = agent.table.copy()
    td = agent.update(s, a, 2.0, s2, terminated)
    assert td == expected_td
    assert agent.table[s, a] == 1.0 + 0.5 * expected_td
    changed = np.argwhere(agent.table != before)
    assert changed.tolist() == [[s, a]]
    assert agent.train_steps == 1


def test_same_state_update_uses_value_before_update() -> None:
    agent = DQDWAAgent(config=DQDWAConfig(alpha=1.0, gamma=0.5))
    agent.table[3, 0] = 4.0
    agent.update(3, 0, 1.0, 3, False)  # target = 1 + 0.5 * 4
    assert agent.table[3, 0] == 3.0


def test_update_rejects_out_of_range() -> None:
    with pytest.raises(ValueError, match="out of range"):
        DQDWAAgent().update(-1, 0, 0.0, 0, False)


def test_learn_discretises_and_act_is_greedy() -> None:
    agent = DQDWAAgent(config=DQDWAConfig(alpha=0.5, gamma=0.5, eps_start=0.0, eps_end=0.0))
    obs, obs2 = make_obs(0.0), make_obs(-90.0, {0: 0.3})
    logs = agent.learn(Transition(obs, 6, 10.0, obs2, False))
    s = agent.state_index(obs)
    assert agent.table[s, 6] == 5.0
    assert logs["losses/td_error"] == 10.0 and agent.env_steps == 1
    assert agent.act(obs) == 6 == agent.act(obs, greedy=True)
    assert agent.act(obs2, greedy=True) == 0  # all-zero row: lowest index


def test_exploration_is_seeded_and_decays_with_updates() -> None:
    cfg = DQDWAConfig(eps_start=1.0, eps_end=0.0, eps_decay=10.0, seed=4)
    a, b = DQDWAAgent(config=cfg), DQDWAAgent(config=cfg)
    obs = make_obs(0.0)
    assert [a.act(obs) for _ in range(50)] == [b.act(obs) for _ in range(50)]
    assert a.epsilon() == 1.0  # acting alone does not decay epsilon
    for _ in range(10):
        a.update(0, 0, 0.0, 0, True)
    assert a.epsilon() == pytest.approx(math.exp(-1.0))
