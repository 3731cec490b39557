"""Replaying bags through a step function: rows, skips with reasons, partial CSV, CLI glue."""

import argparse
import csv
import io
import json

import numpy as np
import pytest

from d3dwa_bullet.cli.transfer import (
    add_compare_arguments,
    add_replay_arguments,
    run_compare,
    run_replay,
)
from d3dwa_bullet.errors import BagFormatError, WriteError
from d3dwa_bullet.planning.observation import build_observation
from d3dwa_bullet.sim.scan import LaserScan, scan_points_body
from tests.support.bag_messages import scan_msg
from transfer import replay as replay_module
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.replay_output import CSV_COLUMNS
from transfer.replay_step import ScanStep, StepOutput
from transfer.synthetic import write_corridor_bag
from transfer.topics import LASER_SCAN, TopicMap

MS = 1_000_000
SCAN_TOPIC = TopicMap().scan


class FakePolicy:
    """Stand-in for estimator + policy + planner: records its inputs, returns a fixed decision."""

    def __init__(self, fail_at: int | None = None):
        self.steps: list[ScanStep] = []
        self.fail_at = fail_at

    def __call__(self, step: ScanStep) -> dict:
        if self.fail_at is not None and len(self.steps) == self.fail_at:
            raise RuntimeError("planner exploded")
        self.steps.append(step)
        obs = build_observation(step.odom_pose, step.odom_twist, step.goal, step.points())
        return {
            "observation": obs,
            "pose": step.odom_pose,
            "velocity": step.odom_twist,
            "action": 30,
            "weights": (1.0, 2.0, 1.0),
            "tau": 4.0,
            "cmd": (0.25, -0.1),
        }


def read_csv(path):
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_replay_feeds_the_step_function_and_writes_everything(tmp_path):
    steps = write_corridor_bag(tmp_path / "bag", n_scans=10, noise_std=0.005, dropout={"nan": 0.1})
    policy = FakePolicy()
    result = replay_bag(tmp_path / "bag", step_fn=policy, out_dir=tmp_path / "out")
    assert (result.scans, result.replayed, result.skipped) == (10, 10, {})
    assert result.status == "complete"
    first = policy.steps[0]
    assert first.t_ns == steps[0][0]
    np.testing.assert_array_equal(first.odom_pose, steps[0][2])
    np.testing.assert_array_equal(first.goal, [5.0, 0.0])
    assert first.imu_w == 0.0 and first.wheel_twist.tolist() == [0.2, 0.0]
    assert result.goal_source.startswith("first message on /goal_pose")

    header, rows = read_csv(tmp_path / "out" / "replay.csv")
    assert tuple(header) == CSV_COLUMNS and len(rows) == 10
    row = dict(zip(header, rows[3], strict=True))
    assert (row["action"], row["tau"], row["cmd_v"]) == ("30", "4.0", "0.25")
    assert (row["rec_cmd_v"], row["rec_action"], row["rec_tau"]) == ("0.2", "30.0", "4.0")
    assert float(row["t"]) == pytest.approx(0.3)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "complete" and summary["replayed"] == 10
    assert summary["topics"]["scan"] == SCAN_TOPIC
    for name in ("path", "sectors", "commands"):
        assert (tmp_path / "out" / f"{name}.png").stat().st_size > 0


def test_replayed_observations_equal_the_simulators_bit_for_bit(tmp_path):
    steps = write_corridor_bag(
        tmp_path / "bag", n_scans=8, noise_std=0.01, dropout={"pos_inf": 0.1}
    )
    result = replay_bag(tmp_path / "bag", out_dir=None)
    mount = result.mount
    for (_, scan, pose), row in zip(steps, result.rows, strict=True):
        sim = build_observation(pose, (0.2, 0.0), (5.0, 0.0), scan_points_body(scan, mount))
        np.testing.assert_array_equal(row.observation, sim)


def test_bad_scans_are_skipped_with_reasons(tmp_path):
    with BagRecorder(tmp_path / "bag", goal=(2.0, 0.0)) as rec:
        for k in range(1, 7):
            rec.write_odometry(k * 100 * MS, (0.0, 0.0, 0.0), (0.0, 0.0))
        good = [1.0] * 10
        scans = [good, [], [np.nan] * 10, [0.0, np.inf, -np.inf, 20.0, np.nan], good, good]
        for k, ranges in enumerate(scans, start=1):
            rec.write_message(
                SCAN_TOPIC, LASER_SCAN, k * 100 * MS, scan_msg(rec, k * 100 * MS, ranges)
            )
        raw = bytes(rec.typestore.serialize_cdr(scan_msg(rec, 650 * MS, good), LASER_SCAN))
        rec.write_raw(SCAN_TOPIC, LASER_SCAN, 650 * MS, raw[:25])
        rec.write_message(SCAN_TOPIC, LASER_SCAN, 700 * MS, scan_msg(rec, 700 * MS, good))
    result = replay_bag(tmp_path / "bag", out_dir=tmp_path / "out", plots=False)
    assert result.scans == 8
    assert result.replayed == 3
    assert result.skipped == {
        "zero beams": 1,
        "all beams invalid": 2,
        "corrupt message": 1,
        "after last odometry sample": 1,
    }
    assert result.replayed + sum(result.skipped.values()) == result.scans
    _, rows = read_csv(tmp_path / "out" / "replay.csv")
    assert len(rows) == 3


def test_odometry_starting_after_the_last_scan_skips_everything(tmp_path):
    with BagRecorder(tmp_path / "bag", goal=(2.0, 0.0)) as rec:
        for k in range(1, 4):
            rec.write_scan(
                k * 100 * MS, LaserScan(-1.0, 0.1, np.ones(10), 0.05, 10.0, k * 100 * MS)
            )
        for k in range(5, 8):
            rec.write_odometry(k * 100 * MS, (0.0, 0.0, 0.0), (0.0, 0.0))
    result = replay_bag(tmp_path / "bag", out_dir=tmp_path / "out")
    assert result.replayed == 0
    assert result.skipped == {"before first odometry sample": 3}
    assert any(n.startswith("no scan overlaps the odometry") for n in result.notes)
    header, rows = read_csv(tmp_path / "out" / "replay.csv")
    assert tuple(header) == CSV_COLUMNS and rows == []


def test_failure_halfway_leaves_the_rows_so_far(tmp_path):
    write_corridor_bag(tmp_path / "bag", n_scans=6)
    with pytest.raises(RuntimeError, match="planner exploded"):
        replay_bag(tmp_path / "bag", step_fn=FakePolicy(fail_at=2), out_dir=tmp_path / "out")
    _, rows = read_csv(tmp_path / "out" / "replay.csv")
    assert len(rows) == 2
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"].startswith("failed: RuntimeError: planner exploded")
    assert summary["replayed"] == 2


def test_goal_is_required(tmp_path):
    write_corridor_bag(tmp_path / "bag", n_scans=3, goal=None)
    with pytest.raises(BagFormatError, match=r"no goal.*/goal_pose.*--goal X,Y"):
        replay_bag(tmp_path / "bag")
    result = replay_bag(tmp_path / "bag", goal=(1.0, 2.0))
    assert result.goal == (1.0, 2.0) and result.goal_source.startswith("argument")


def test_odometry_is_required(tmp_path):
    with BagRecorder(tmp_path / "bag") as rec:
        rec.write_scan(MS, LaserScan(-1.0, 0.1, np.ones(10), 0.05, 10.0, MS))
    with pytest.raises(BagFormatError, match=r"bag: no odometry"):
        replay_bag(tmp_path / "bag", goal=(1.0, 0.0))


def test_wheel_odometry_stands_in_for_missing_odometry(tmp_path):
    write_corridor_bag(tmp_path / "bag", n_scans=4, topics=TopicMap(odometry=None))
    result = replay_bag(tmp_path / "bag")
    assert result.replayed == 4
    assert any("pose source is wheel odometry" in n for n in result.notes)


def test_step_output_dataclass_is_accepted(tmp_path):
    write_corridor_bag(tmp_path / "bag", n_scans=2)

    def step(s: ScanStep) -> StepOutput:
        return StepOutput(observation=np.zeros(12), pose=s.odom_pose, velocity=(0.0, 0.0))

    result = replay_bag(tmp_path / "bag", step_fn=step)
    assert np.isnan(result.column("tau")).all()
    assert result.column("obs_d_goal").tolist() == [0.0, 0.0]


def test_cli_replay_and_compare(tmp_path):
    write_corridor_bag(tmp_path / "a", n_scans=4, topics=TopicMap(scan="/scan"))
    write_corridor_bag(tmp_path / "b", n_scans=4, noise_std=0.01, dropout={"nan": 0.2})
    parser = argparse.ArgumentParser()
    add_replay_arguments(parser)
    args = parser.parse_args(
        [str(tmp_path / "a"), "--out", str(tmp_path / "out"), "--json", "--no-plots"]
    )
    out = io.StringIO()
    assert run_replay(args, out=out) == 0
    summary = json.loads(out.getvalue())
    assert summary["topics"]["scan"] == "/scan"
    assert any("using '/scan'" in n for n in summary["notes"])

    args = parser.parse_args(
        [str(tmp_path / "b"), "--out", str(tmp_path / "o2"), "--goal", "1,0", "--no-plots"]
    )
    out = io.StringIO()
    assert run_replay(args, out=out) == 0
    assert "goal: (1.000, 0.000) from argument" in out.getvalue()

    parser = argparse.ArgumentParser()
    add_compare_arguments(parser)
    out = io.StringIO()
    assert run_compare(parser.parse_args([str(tmp_path / "a"), str(tmp_path / "b")]), out=out) == 0
    assert "| sector |" in out.getvalue() and "/scan" in out.getvalue()


def test_replay_never_writes_its_csv_through_a_link_in_out(tmp_path):
    write_corridor_bag(tmp_path / "bag")
    out, outside = tmp_path / "out", tmp_path / "precious.csv"
    out.mkdir()
    outside.write_text("not a replay\n")
    (out / "replay.csv").symlink_to(outside)
    with pytest.raises(WriteError, match="replay.csv: cannot write: it is a symbolic link"):
        replay_bag(tmp_path / "bag", out_dir=out, plots=False)
    assert outside.read_text() == "not a replay\n"


def test_replay_keeps_an_earlier_csv_whole_until_it_ends(tmp_path, monkeypatch):
    write_corridor_bag(tmp_path / "bag")
    out = tmp_path / "out"
    replay_bag(tmp_path / "bag", out_dir=out, plots=False)
    earlier = (out / "replay.csv").read_text()
    assert earlier.count("\n") > 2

    seen: list[str] = []
    real = replay_module._run

    def watch(*args, **kwargs):  # what replay.csv holds while the new replay runs
        seen.append((out / "replay.csv").read_text())
        return real(*args, **kwargs)

    monkeypatch.setattr(replay_module, "_run", watch)
    replay_bag(tmp_path / "bag", out_dir=out, plots=False)
    assert seen == [earlier]
    assert (out / "replay.csv").read_text().count("\n") == earlier.count("\n")  # same bag
    assert not (out / replay_module.PARTIAL_CSV).exists()
