"""The history observation (docs/design/observation.md#history-observation): the paper's state over the last
10 control steps and the previous action, built alike by the simulator and the bag replay, and
refused wherever a method of the other kind would feed it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.history import HISTORY_LAYOUT, HISTORY_STEPS, HistoryObserver
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.planning.observation_kinds import (
    kind_of_layout,
    make_observer,
    observation_layout,
    observation_low,
)
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.planning.progress import PREVIOUS_ACTION_LAYOUT
from d3dwa_bullet.world.registry import load_world
from tests.transfer.test_transfer_roundtrip import record, round_trip_report
from transfer.replay import replay_bag
from transfer.sim_bridge import make_step_fn

PAPER = len(OBSERVATION_LAYOUT)


def test_the_layout_is_this_step_then_nine_past_steps_then_the_previous_action() -> None:
    assert observation_layout("history") == HISTORY_LAYOUT
    assert len(HISTORY_LAYOUT) == PAPER * HISTORY_STEPS + 4 == 124
    assert HISTORY_LAYOUT[:PAPER] == OBSERVATION_LAYOUT
    assert HISTORY_LAYOUT[PAPER : 2 * PAPER] == tuple(f"{n}@-1" for n in OBSERVATION_LAYOUT)
    assert HISTORY_LAYOUT[-4:] == PREVIOUS_ACTION_LAYOUT
    assert len(set(HISTORY_LAYOUT)) == len(HISTORY_LAYOUT)
    assert kind_of_layout(HISTORY_LAYOUT) == "history"
    assert isinstance(make_observer("history"), HistoryObserver)
    # theta_goal, v and w are signed at every lag, everything else is in [0, 1]
    low = observation_low(HISTORY_LAYOUT).reshape(-1)[: PAPER * HISTORY_STEPS]
    assert (low.reshape(HISTORY_STEPS, PAPER) == [0, -1, -1, -1] + [0] * 8).all()
    assert (observation_low(HISTORY_LAYOUT)[-4:] == 0).all()


def test_each_lag_holds_the_observation_that_many_steps_ago() -> None:
    observer = HistoryObserver()
    seen = [np.full(PAPER, k / 100.0) for k in range(14)]
    action = PlannerAction(3.0, 1.0, 2.0, 5.0)
    outs = []
    for k, obs in enumerate(seen):
        outs.append(observer.extend(obs, k, (0.0, 0.0, 0.0)))
        observer.chose(action)
    for t, out in enumerate(outs):
        blocks = out[: PAPER * HISTORY_STEPS].reshape(HISTORY_STEPS, PAPER)
        for lag in range(HISTORY_STEPS):
            # before ten steps exist, the missing past repeats the oldest one seen
            np.testing.assert_array_equal(blocks[lag], seen[max(t - lag, 0)])
    assert outs[0][-4:].tolist() == [0.0] * 4  # nothing chosen yet
    assert outs[1][-4:].tolist() == [1.0, 1 / 3, 2 / 3, 1.0]


def test_a_wrong_shaped_observation_is_refused() -> None:
    with pytest.raises(ValueError, match=r"\(12,\) paper observation, got shape \(17,\)"):
        HistoryObserver().extend(np.zeros(17), 0, (0.0, 0.0, 0.0))


def test_the_paper_entries_of_a_history_episode_are_the_papers() -> None:
    world = load_world("TS4").with_task(time_limit=3.0)
    controller = make_controller("dwa3")
    noise = lambda: make_noise("harsh", 4)  # noqa: E731  # a fresh model per episode
    paper = run_episode(world, controller, 4, noise(), "harsh")
    history = run_episode(world, replace(controller, observation="history"), 4, noise(), "harsh")
    assert paper.summary() == history.summary()
    assert history.observations.shape == (30, 124)
    assert np.array_equal(paper.observations, history.observations[:, :PAPER])
    # under noise too, the step before is the last step's state as it was seen then
    past = history.observations[1:, PAPER : 2 * PAPER]
    assert np.array_equal(past, history.observations[:-1, :PAPER])


def test_the_env_gives_the_agent_124_entries_inside_its_box() -> None:
    env = D3DWAEnv(observation="history", decision_steps=10, noise=("harsh",))
    obs, _ = env.reset(seed=3)
    assert obs.shape == (124,) and env.observation_space.contains(obs)
    nxt, *_ = env.step(57)
    assert env.observation_space.contains(nxt)
    # one decision held for 10 control steps: the oldest lag is the first step after it
    assert not np.array_equal(nxt[:PAPER], nxt[PAPER * 9 : PAPER * 10])
    assert nxt[-4:].tolist() == pytest.approx(
        [a / d for a, d in zip(ACTIONS_FULL.decode(57), (3, 3, 3, 5), strict=True)]
    )
    env.close()


@pytest.fixture(scope="module")
def history_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An untrained D3QN reading the history observation: its choices vary with it."""
    agent = D3QNAgent(
        ACTIONS_FULL, D3QNConfig(hidden=(32, 32), seed=3), observation_layout("history")
    )
    return save_checkpoint(tmp_path_factory.mktemp("hist") / "h", agent, method="d3dwa-history-dr")


def test_a_recorded_history_episode_replays_to_the_same_124_entries(history_policy, tmp_path):
    bag = tmp_path / "bag"
    episode = record(bag, "R1", "d3dwa-history-dr", history_policy, "real", seed=2)
    replay = replay_bag(bag, step_fn=make_step_fn("d3dwa-history-dr", history_policy))
    report = round_trip_report(episode, replay)
    assert episode.observations.shape[1] == 124
    assert report["max_obs_diff"] == 0.0 and report["action_agreement"] == 1.0
    assert report["distinct_actions"] >= 2


@pytest.mark.parametrize(
    ("method", "policy_kind", "have", "want"),
    [
        ("d3dwa-dr", "history", "'history' observation (124 entries)", "'paper' observation"),
        ("d3dwa-history-dr", "paper", "'paper' observation (12 entries)", "'history' observation"),
    ],
)
def test_a_policy_of_the_other_kind_is_refused_in_one_line(
    tmp_path, capsys, method, policy_kind, have, want
):
    agent = D3QNAgent(
        ACTIONS_FULL, D3QNConfig(hidden=(8,), seed=0), observation_layout(policy_kind)
    )
    policy = save_checkpoint(tmp_path / "p", agent, method="d3dwa")
    code = main(["run", "--method", method, "--policy", str(policy), "--world", "TS1"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1
    assert f"reads the {have}" in lines[0] and f"feeds the {want}" in lines[0]
