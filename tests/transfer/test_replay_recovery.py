"""The replay pipeline runs the recovery layer as ``Episode.act`` does, on the episode's clock:
a bag recorded with ``--recovery nav2`` replays to its recorded commands."""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.params import recovery_params
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.sim_bridge import DEFAULT_START_NS, ReplayPipeline, make_step_fn, record_episode

NAV2 = EpisodeConfig(recovery=recovery_params("nav2"))


def test_recovery_clock_is_the_episode_clock_on_the_control_grid():
    pipeline = ReplayPipeline(make_controller("dwa3"), config=NAV2)
    start = DEFAULT_START_NS
    assert pipeline.recovery_clock(start) == 0.0
    for k in (3, 7, 12, 23):  # ns / 1e9 differs from k * 0.1 in the last bit for these
        assert pipeline.recovery_clock(start + round(k * 0.1 * 1e9)) == k * 0.1
        assert round(k * 0.1 * 1e9) / 1e9 != k * 0.1
    assert pipeline.recovery_clock(start + 123_456_789) == 0.123456789  # off the grid


def test_a_recovering_episode_replays_to_its_commands(tmp_path):
    bag = tmp_path / "us1"
    with BagRecorder(bag) as recorder:
        summary = record_episode("US1", "dwa3", None, "none", 0, recorder, config=NAV2)
    assert summary["recovery"] == "nav2"
    replay = replay_bag(bag, step_fn=make_step_fn("dwa3", config=NAV2), plots=False)
    cmd = np.array([row.cmd for row in replay.rows])
    recorded = np.array([row.recorded_cmd for row in replay.rows])
    assert len(cmd) == summary["steps"]
    spins = (recorded[:, 0] == 0.0) & (recorded[:, 1] != 0.0)
    assert spins.sum() > 5  # the recovery layer drove some steps
    np.testing.assert_array_equal(cmd, recorded)


def test_a_filtered_episode_replays_to_its_commands_only_with_its_filter(tmp_path):
    # The bag holds the scans as the lidar gave them; replay filters them as Episode did.
    median = EpisodeConfig(scan_filter="median")
    bag = tmp_path / "r1"
    with BagRecorder(bag) as recorder:
        summary = record_episode("R1", "dwa3", None, "harsh", 0, recorder, config=median,
                                 time_limit=6.0)  # fmt: skip
    replay = replay_bag(bag, step_fn=make_step_fn("dwa3", config=median), plots=False)
    cmd = np.array([row.cmd for row in replay.rows])
    recorded = np.array([row.recorded_cmd for row in replay.rows])
    assert len(cmd) == summary["steps"]
    np.testing.assert_array_equal(cmd, recorded)
    raw = replay_bag(bag, step_fn=make_step_fn("dwa3"), plots=False)
    assert not np.array_equal(np.array([row.cmd for row in raw.rows]), recorded)
