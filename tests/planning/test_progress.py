"""The progress-aware observation (docs/design/observation.md#progress-observation): the paper's 12-d state
is unchanged bit for bit, and a robot that stands still no longer sees a fixed state."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, recovery_result, run_episode
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.method_specs import METHODS, method_observation
from d3dwa_bullet.params import PROGRESS_RADIUS, PROGRESS_WINDOW, ProgressObservationParams
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT, build_observation
from d3dwa_bullet.planning.observation_kinds import (
    check_observation_kind,
    kind_of_layout,
    observation_layout,
)
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.planning.progress import (
    PROGRESS_LAYOUT,
    NoProgressClock,
    ProgressObserver,
    progress_features,
)
from d3dwa_bullet.planning.recovery import RecoveryCommand
from d3dwa_bullet.world.registry import load_world

S = 1_000_000_000  # ns per s
POINTS = np.array([[1.0, 0.2], [0.3, -0.8], [-0.2, 1.5], [2.0, 2.0], [0.5, 0.01]])
PAPER_OBS_HEX = [
    "0x1.4bec732d17a4cp-1", "-0x1.f7c2a62b066d3p-4", "0x1.4000000000000p-1",
    "-0x1.3333333333333p-2", "0x1.0000000000000p+0", "0x1.f3f23f29d6791p-3",
    "0x1.0000000000000p+0", "0x1.0000000000000p+0", "0x1.24a1438d3b1bap-3",
    "0x1.9dc22be484458p-1", "0x1.0000000000000p+0", "0x1.babdac48a7d95p-2",
]  # fmt: skip
"""build_observation of POINTS from pose (0.3, -0.2, 0.7), velocity (0.25, -0.6), goal
(4, 1), recorded with the code before the progress kind existed (commit d7552a8)."""


def test_paper_observation_is_bit_identical_to_before() -> None:
    obs = build_observation((0.3, -0.2, 0.7), (0.25, -0.6), (4.0, 1.0), POINTS)
    assert [float(x).hex() for x in obs] == PAPER_OBS_HEX
    assert observation_layout("paper") == OBSERVATION_LAYOUT
    assert observation_layout("progress") == OBSERVATION_LAYOUT + PROGRESS_LAYOUT
    assert kind_of_layout(list(OBSERVATION_LAYOUT)) == "paper"
    assert kind_of_layout(OBSERVATION_LAYOUT[:-1]) is None


@pytest.mark.parametrize("kind", ["", "Paper", "progress-aware", None, 12])
def test_unknown_observation_kinds_are_refused_by_name(kind: object) -> None:
    with pytest.raises(ConfigError, match=r"TrainConfig\.observation: unknown observation kind"):
        check_observation_kind(kind, "TrainConfig.observation")


def test_every_registered_method_but_the_history_one_reads_the_papers_observation() -> None:
    kinds = {m: method_observation(m) for m in METHODS}
    assert {m for m, k in kinds.items() if k != "paper"} == {"d3dwa-history-dr"}
    assert kinds["d3dwa-history-dr"] == "history"
    assert make_controller("dwa3").observation == "paper"


def test_no_progress_clock_follows_the_progress_checker() -> None:
    clock = NoProgressClock(PROGRESS_RADIUS)
    assert clock.update(7 * S, (1.0, 1.0, 0.0)) == 0.0  # the first call sets the baseline
    assert clock.update(8 * S, (1.0, 1.0, 3.0)) == 1.0  # turning in place is no progress
    assert clock.update(9 * S, (1.0 + PROGRESS_RADIUS, 1.0, 0.0)) == 2.0  # on the circle
    assert clock.update(10 * S, (1.0 + PROGRESS_RADIUS + 1e-9, 1.0, 0.0)) == 0.0  # left it
    assert clock.update(10 * S + 100_000_000, (1.6, 1.0, 0.0)) == pytest.approx(0.1, abs=0)


def test_progress_features_are_normalised_and_clipped() -> None:
    params = ProgressObservationParams()
    assert progress_features(0.0, None, params).tolist() == [0.0] * 5
    feats = progress_features(2.5, PlannerAction(1.0, 3.0, 2.0, 4.0), params)
    np.testing.assert_allclose(feats, [2.5 / PROGRESS_WINDOW, 1 / 3, 1.0, 2 / 3, 0.8])
    assert progress_features(1e6, None, params)[0] == 1.0
    with pytest.raises(ConfigError, match="window"):
        ProgressObservationParams(window=0.0)


def test_a_standing_robot_with_one_action_is_no_longer_a_fixed_point() -> None:
    """The paper's state of a robot at v = 0 repeats, and so would the greedy action; the
    progress entries keep moving until the window runs out."""
    observer = ProgressObserver()
    paper = build_observation((0.0, 0.0, 0.0), (0.0, 0.0), (3.0, 0.0), POINTS)
    action = PlannerAction(1.0, 1.0, 2.0, 4.0)
    states = []
    for k in range(12):
        states.append(observer.extend(paper, k * S, (0.0, 0.0, 0.0)))
        observer.chose(action)
    assert all(np.array_equal(s[:12], paper) for s in states)
    stalled = [s[12] for s in states]
    assert stalled == sorted(stalled) and len(set(stalled)) == 11  # 0, 0.1, ..., 1.0, 1.0
    assert stalled[-1] == 1.0
    assert states[0][13:].tolist() == [0.0] * 4 and states[1][13:].tolist() == [
        1 / 3,
        1 / 3,
        2 / 3,
        0.8,
    ]


def test_progress_entries_change_while_a_simulated_robot_stands_still(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the planner commands a stop every step: the robot stands, its scan and estimate repeat
    stop = recovery_result(RecoveryCommand(0.0, 0.0, "spin"))
    monkeypatch.setattr("d3dwa_bullet.episode.plan", lambda *args: stop)
    action = PlannerAction(2.0, 1.0, 1.0, 3.0)
    with Episode(load_world("TS1"), observation="progress") as ep:
        seen = [ep.observe()]
        for _ in range(30):
            ep.act(-1, action)
            seen.append(ep.observe())
    obs = np.array(seen)
    assert obs.shape == (31, 17)
    # the paper's entries settle to a fixed point once the robot has come to rest ...
    late = obs[11:, :12]
    assert np.abs(late - late[-1]).max() < 1e-3  # a tenth of what one step adds below
    # ... while the time without progress keeps counting, 0.01 of the window per step
    np.testing.assert_allclose(obs[:, 12], np.arange(31) * 0.1 / PROGRESS_WINDOW, atol=1e-12)
    assert (obs[1:, 13:] == [2 / 3, 1 / 3, 1 / 3, 0.6]).all()


def test_the_paper_entries_of_an_episode_do_not_depend_on_the_kind() -> None:
    world = load_world("TS4").with_task(time_limit=4.0)
    controller = make_controller("dwa3")
    paper = run_episode(world, controller)
    progress = run_episode(world, replace(controller, observation="progress"))
    assert paper.summary() == progress.summary()
    assert paper.observations.shape == (40, 12) and progress.observations.shape == (40, 17)
    assert np.array_equal(paper.observations, progress.observations[:, :12])
    np.testing.assert_array_equal(progress.observations[1:, 13:], [[2 / 3, 1 / 3, 1 / 3, 0.8]] * 39)
