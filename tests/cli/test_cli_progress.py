"""The progress-aware methods on the command line and through bags: a policy of the other
observation kind, an unknown kind and a bag without odometry are refused in one line (exit 2);
a recorded d3dwa-pa episode replays to the same 17 entries and actions, bit for bit."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.cli.options import default_methods
from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.progress import observation_layout
from tests.support.bag_messages import scan_msg
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.replay_output import csv_columns
from transfer.sim_bridge import make_step_fn, record_episode
from transfer.topics import LASER_SCAN, TopicMap

MS = 1_000_000


def run(capsys: pytest.CaptureFixture, *argv: object) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("d3dwa: error: "), err
    return lines[0]


@pytest.fixture(scope="module")
def pa_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An untrained D3QN reading the progress observation: its choices vary with it."""
    agent = D3QNAgent(
        ACTIONS_FULL, D3QNConfig(hidden=(32, 32), seed=3), observation_layout("progress")
    )
    return save_checkpoint(tmp_path_factory.mktemp("pa") / "d3dwa-pa", agent, method="d3dwa-pa")


def test_a_paper_policy_is_refused_for_d3dwa_pa_and_the_other_way(pa_policy, tmp_path, capsys):
    shipped = default_policy_path("d3dwa")  # seed folders: `run` drives the lowest seed
    code, err = run(capsys, "run", "--method", "d3dwa-pa", "--policy", shipped, "--world", "TS1")
    line = error_line(err)
    assert code == 2 and "seed-0/meta.json" in line
    assert "the policy reads the 'paper' observation (12 entries)" in line
    assert "method 'd3dwa-pa' feeds the 'progress' observation (17 entries)" in line
    code, err = run(capsys, "run", "--method", "d3dwa", "--policy", pa_policy, "--world", "TS1")
    line = error_line(err)
    assert code == 2 and "reads the 'progress' observation (17 entries)" in line
    assert "method 'd3dwa' feeds the 'paper' observation (12 entries)" in line


def test_an_unknown_observation_kind_in_a_training_config(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text("method: d3dwa-pa\nobservation: history\ntotal_steps: 100\n")
    code, err = run(capsys, "train", "--config", config, "--out", tmp_path / "run")
    line = error_line(err)
    assert code == 2 and str(config) in line and "TrainConfig.observation" in line
    assert "'history'" in line and "paper, progress" in line
    assert not (tmp_path / "run").exists()
    config.write_text("method: d3dwa\nobservation: progress\n")
    code, err = run(capsys, "train", "--config", config, "--out", tmp_path / "run")
    assert code == 2 and "method 'd3dwa' reads the 'paper' observation" in error_line(err)


def test_a_bag_without_odometry_through_a_progress_aware_policy(pa_policy, tmp_path, capsys):
    topics = TopicMap()
    with BagRecorder(tmp_path / "bag", goal=(2.0, 0.0)) as rec:
        for k in range(1, 4):
            rec.write_message(
                topics.scan, LASER_SCAN, k * 100 * MS, scan_msg(rec, k * 100 * MS, [1.0] * 21)
            )
    code, err = run(
        capsys, "replay", tmp_path / "bag", "--method", "d3dwa-pa", "--policy", pa_policy,
        "--out", tmp_path / "o",
    )  # fmt: skip
    line = error_line(err)
    assert code == 2 and str(tmp_path / "bag") in line and "no odometry" in line
    assert topics.odometry in line and topics.wheel_odometry in line


def test_a_recorded_d3dwa_pa_episode_replays_bit_for_bit(pa_policy, tmp_path):
    results = []
    with BagRecorder(tmp_path / "bag") as rec:
        record_episode("TS4", "d3dwa-pa", pa_policy, "real", 1, rec, time_limit=4.0,
                       on_result=results.append)  # fmt: skip
    episode = results[0]
    replay = replay_bag(tmp_path / "bag", make_step_fn("d3dwa-pa", pa_policy), out_dir=tmp_path / "o",
                        plots=False)  # fmt: skip
    obs = np.array([r.observation for r in replay.rows])
    assert obs.shape == episode.observations.shape == (40, 17)
    assert np.array_equal(obs, episode.observations)  # the progress entries included
    assert [r.action for r in replay.rows] == episode.log["action"].astype(int).tolist()
    assert len(set(obs[:, 12].tolist())) > 1 and (obs[1:, 13:] > 0).all()
    with (tmp_path / "o" / "replay.csv").open(newline="") as fh:
        header = next(csv.reader(fh))
    assert tuple(header) == csv_columns(observation_layout("progress"))
    assert "obs_stalled" in header and "obs_prev_tau" in header


def test_the_main_jobs_default_methods_are_the_papers_with_a_shipped_policy() -> None:
    methods = default_methods()
    assert methods[:3] == ["dwa1", "dwa2", "dwa3"]
    for method in ("d3dwa-pa", "d3dwa-pa-dr"):  # beyond the paper: only when named
        assert method not in methods
    for method in ("dqdwa", "d3dwa-weights", "d3dwa", "d3dwa-dr"):
        assert (method in methods) == default_policy_path(method).exists()
