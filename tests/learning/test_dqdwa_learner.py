"""DQDWA's learner options: n-step targets and a step size that falls with visits (both off by
default), their checks, and a run with them that resumes exactly."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.dqdwa import Discretisation, DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.agents.training_state import restore_training_state
from d3dwa_bullet.learning.training import TrainConfig, train
from d3dwa_bullet.planning.actions import ACTIONS_WEIGHTS_ONLY

from .test_dqdwa import make_obs
from .test_training import TINY_WORLD, _interrupt_at


def _obs(k: int) -> np.ndarray:
    """Observations in distinct table rows (goal bearing 5 bins x nearest distance 3 bins)."""
    return make_obs([-90.0, -30.0, 0.0, 30.0, 90.0][k % 5], {4: [0.3, 0.8, 1.5][k // 5]})


def test_defaults_are_the_one_step_constant_step_size_update() -> None:
    cfg = DQDWAConfig()
    assert cfg.n_step == 1 and cfg.alpha_schedule == "constant"
    agent = DQDWAAgent(config=DQDWAConfig(alpha=0.5, gamma=0.5))
    agent.update(1, 2, 4.0, 3, True)
    agent.update(1, 2, 4.0, 3, True)
    assert agent.table[1, 2] == 2.0 + 0.5 * 2.0  # 0.5 every time, not 1 / visits


def test_visits_schedule_sets_then_averages_then_floors() -> None:
    agent = DQDWAAgent(config=DQDWAConfig(alpha=0.2, alpha_schedule="visits", initial_q=-9.0))
    for target in (10.0, 4.0, 1.0):
        agent.update(0, 0, target, 0, True)
    assert agent.table[0, 0] == pytest.approx(5.0)  # the mean of 10, 4, 1: no pull to -9
    agent.update(0, 0, 5.0 + 20.0, 0, True)  # 1/4 -> step 0.25
    assert agent.table[0, 0] == pytest.approx(10.0)
    for _ in range(6):  # visits 5..10: 1/5 then the 0.2 floor
        before = agent.table[0, 0]
        agent.update(0, 0, before + 1.0, 0, True)
        assert agent.table[0, 0] - before == pytest.approx(0.2)
    assert agent.visits[0, 0] == 10 and agent.visits.sum() == 10


def test_n_step_targets_fold_rewards_per_env_and_flush_at_the_end() -> None:
    cfg = DQDWAConfig(alpha=1.0, gamma=0.5, n_step=3)
    agent = DQDWAAgent(config=cfg)
    s = [agent.state_index(_obs(k)) for k in range(6)]
    assert len(set(s)) == 6
    agent.table[s[3]] = 8.0  # the bootstrap after three steps
    logs = [agent.learn(Transition(_obs(k), k, 1.0, _obs(k + 1), False), env=0) for k in range(2)]
    agent.learn(Transition(_obs(4), 7, 100.0, _obs(5), False), env=1)  # another env: its own window
    assert all("losses/td_error" not in entry for entry in logs) and agent.train_steps == 0
    agent.learn(Transition(_obs(2), 2, 1.0, _obs(3), False), env=0)
    assert agent.table[s[0], 0] == 1.0 + 0.5 + 0.25 + 0.125 * 8.0  # r0 + g r1 + g^2 r2 + g^3 max Q
    assert agent.train_steps == 1
    agent.learn(Transition(_obs(3), 3, 2.0, _obs(4), True), env=0)  # a goal: the rest flushes
    assert agent.table[s[1], 1] == 1.0 + 0.5 * 1.0 + 0.25 * 2.0  # no bootstrap past the goal
    assert agent.table[s[2], 2] == 1.0 + 0.5 * 2.0 and agent.table[s[3], 3] == 2.0
    assert agent.train_steps == 4 and agent.n_step_windows.pending() == 1  # env 1's step waits


@pytest.mark.parametrize(
    ("field", "value"),
    [("alpha_schedule", "harmonic"), ("n_step", 0), ("n_step", 601), ("n_step", 2.5),
     ("n_step", True)],
)  # fmt: skip
def test_bad_learner_options_are_named(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=f"DQDWAConfig.{field}"):
        DQDWAConfig.from_dict({field: value})


def _config(world: str, **changes: object) -> TrainConfig:
    agent = DQDWAConfig(eps_decay=50.0, n_step=6, alpha_schedule="visits", alpha=0.05)
    base = dict(method="dqdwa", total_steps=90, worlds=(world,), generators=(), agent=agent,
                eval_every=0, eval_worlds=(world,), checkpoint_every=0, log_every=20,
                keep="final", n_envs=1)  # fmt: skip
    return TrainConfig(**(base | changes))  # type: ignore[arg-type]


def test_a_run_with_both_options_resumes_exactly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    world = tmp_path / "tiny.yaml"
    world.write_text(TINY_WORLD)
    config = _config(str(world))
    a, b = tmp_path / "a", tmp_path / "b"
    train(config, a, progress=False)
    with monkeypatch.context() as m:
        _interrupt_at(m, 41)
        stopped = train(replace(config, total_steps=90), b, progress=False)
    assert stopped["status"] == "interrupted"
    state = json.loads((b / "checkpoints/latest/training_state.json").read_text())
    assert sum(map(sum, state["visits"])) == stopped["train_steps"] > 0
    assert train(None, b, resume=True, progress=False)["status"] == "done"
    ta, tb = (np.load(d / "policy" / "table.npy") for d in (a, b))
    np.testing.assert_array_equal(ta, tb)
    assert not np.all(ta == 0)


def test_visits_of_another_table_are_refused(tmp_path: Path) -> None:
    world = tmp_path / "tiny.yaml"
    world.write_text(TINY_WORLD)
    train(_config(str(world), total_steps=30), tmp_path / "r", progress=False)
    coarser = Discretisation(distance_edges=(0.5,))  # 90 states, not 135
    agent = DQDWAAgent(ACTIONS_WEIGHTS_ONLY, DQDWAConfig(discretisation=coarser))
    with pytest.raises(CheckpointError, match=r"'visits' has shape \(135, 25\)"):
        restore_training_state(tmp_path / "r/checkpoints/latest", agent)
