"""A velocity planner from outside the package through a bag: ``record`` then ``replay``
gives its recorded commands back, bit for bit, with and without the recovery layer around it
(docs/design/external-methods.md#external-methods)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, run_episode
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.world.registry import load_world
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.sim_bridge import make_step_fn, record_episode

FTG = Path(__file__).resolve().parents[2] / "examples" / "follow_the_gap"
NAV2 = EpisodeConfig(recovery=recovery_params("nav2"))


@pytest.mark.parametrize(
    ("method", "world", "config", "limit"),
    [
        ("follow_the_gap.planner:FollowTheGap", "R2", EpisodeConfig(), 12.0),
        ("tests.support.external_methods:LookThenStill", "R1", NAV2, 16.0),
    ],
)
def test_a_recorded_external_planner_replays_to_its_commands(
    tmp_path, monkeypatch, method, world, config, limit
):
    monkeypatch.syspath_prepend(str(FTG))
    bag = tmp_path / "bag"
    with BagRecorder(bag) as recorder:
        summary = record_episode(
            world, method, None, "real", 1, recorder, config=config, time_limit=limit
        )
    replay = replay_bag(bag, step_fn=make_step_fn(method, config=config), plots=False)
    cmd = np.array([row.cmd for row in replay.rows])
    recorded = np.array([row.recorded_cmd for row in replay.rows])
    assert len(cmd) == summary["steps"] > 50
    np.testing.assert_array_equal(cmd, recorded)
    assert all(row.action == -1 and np.isnan(row.tau) for row in replay.rows)
    if config.recovery is not None:  # the planner stands still: the layer turns the robot
        moved = run_episode(
            load_world(world).with_task(time_limit=limit), make_controller(method), config=config
        )
        rescued = moved.log["recovery"] > 0
        assert rescued.sum() > 5 and np.abs(moved.log["w_cmd"][rescued]).max() > 0.5
