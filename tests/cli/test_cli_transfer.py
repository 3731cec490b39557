"""``d3dwa record`` and ``d3dwa replay`` end to end, and what they do with bad input.

Bad input never ends in a traceback: one ``d3dwa: error: ...`` line naming the bag (and the
topic where one is at fault), a non-zero exit, and whatever could be replayed on disk.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from tests.support.bag_messages import scan_msg
from tests.support.cli import run
from transfer import sim_bridge as transfer_bridge
from transfer.bag_writer import BagRecorder
from transfer.replay import CSV_COLUMNS, ScanStep, SkipScan, replay_bag
from transfer.topics import LASER_SCAN, TopicMap

MS = 1_000_000
TOPICS = TopicMap()


def error_line(err: str) -> str:
    """The CLI's error output must be exactly one line."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("d3dwa: error: "), err
    return lines[0]


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def recorded_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("rec") / "r2"
    code = main(
        [
            "record",
            "--world",
            "R2",
            "--method",
            "dwa2",
            "--out",
            str(bag),
            "--noise",
            "real",
            "--seed",
            "1",
            "--time-limit",
            "2",
        ]
    )
    assert code == 0
    return bag


def test_record_then_replay_json(recorded_bag, tmp_path, capsys):
    code, out, err = run(
        capsys, "replay", recorded_bag, "--method", "dwa2", "--out", tmp_path / "o", "--json"
    )
    assert code == 0, err
    summary = json.loads(out)
    assert {"scans", "replayed", "skipped", "topics"} <= summary.keys()
    assert (summary["scans"], summary["replayed"], summary["skipped"]) == (20, 20, {})
    assert summary["topics"]["scan"] == TOPICS.scan
    rows = read_rows(tmp_path / "o" / "replay.csv")
    assert len(rows) == 20 and tuple(rows[0]) == CSV_COLUMNS
    for row in rows:  # the replayed decision is the recorded one
        assert (row["cmd_v"], row["cmd_w"]) == (row["rec_cmd_v"], row["rec_cmd_w"])
        assert (row["wp"], row["wc"], row["ws"], row["tau"]) == ("1.0", "2.0", "1.0", "4.0")
    for name in ("path", "sectors", "commands"):
        assert (tmp_path / "o" / f"{name}.png").stat().st_size > 0


def test_replay_with_a_learned_policy_and_the_ekf(recorded_bag, tmp_path, capsys):
    from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
    from d3dwa_bullet.planning.actions import ACTIONS_WEIGHTS_ONLY

    agent = D3QNAgent(ACTIONS_WEIGHTS_ONLY, D3QNConfig(hidden=(16,), seed=1))
    policy = save_checkpoint(tmp_path / "pol", agent, method="d3dwa-weights")
    code, out, err = run(
        capsys,
        "replay",
        recorded_bag,
        "--method",
        "d3dwa-weights",
        "--policy",
        policy,
        "--estimator",
        "ekf",
        "--out",
        tmp_path / "o",
        "--no-plots",
    )
    assert code == 0, err
    assert "replayed: 20" in out
    rows = read_rows(tmp_path / "o" / "replay.csv")
    assert {row["tau"] for row in rows} == {"4.0"} and all(int(row["action"]) >= 0 for row in rows)


def test_record_refuses_to_overwrite_and_leaves_no_bag_on_bad_names(recorded_bag, tmp_path, capsys):
    code, _, err = run(capsys, "record", "--world", "R2", "--method", "dwa2", "--out", recorded_bag)
    assert code == 2 and "bag exists" in error_line(err)
    code, _, err = run(
        capsys, "record", "--world", "R9", "--method", "dwa2", "--out", tmp_path / "b"
    )
    assert code == 2 and "unknown world 'R9'" in error_line(err)
    assert not (tmp_path / "b").exists()  # a retry is not blocked by an empty bag


def test_a_recording_that_fails_halfway_keeps_its_steps(tmp_path, capsys, monkeypatch):
    def failing_episode(world, method, policy, noise, seed, recorder, **_):
        for k in range(3):
            t = (k + 1) * 100 * MS
            scan = LaserScan(-1.0, 0.1, np.ones(21), 0.05, 10.0, t)
            recorder.write_step(t, scan, (0.1 * k, 0.0, 0.0), (0.1, 0.0), cmd=(0.1, 0.0))
        raise RuntimeError("physics exploded")

    monkeypatch.setattr(transfer_bridge, "record_episode", failing_episode)
    code, _, err = run(
        capsys, "record", "--world", "R1", "--method", "dwa1", "--out", tmp_path / "b"
    )
    line = error_line(err)
    assert code == 2 and str(tmp_path / "b") in line and "RuntimeError: physics exploded" in line
    result = replay_bag(tmp_path / "b", goal=(1.0, 0.0))  # the bag is closed and readable
    assert result.replayed == 3


# -- bad input -------------------------------------------------------------------------


def write_bag(
    path: Path,
    scans: list[list[float]] | None = None,
    odometry_steps: range = range(1, 7),
    goal: tuple[float, float] | None = (2.0, 0.0),
    corrupt_at: int | None = None,
) -> Path:
    """Scans k = 1, 2, ... at k * 100 ms; odometry at the given steps (robot at rest)."""
    with BagRecorder(path, goal=goal) as rec:
        for k in odometry_steps:
            rec.write_odometry(k * 100 * MS, (0.0, 0.0, 0.0), (0.0, 0.0))
        for k, ranges in enumerate(scans or [], start=1):
            t = k * 100 * MS
            if k == corrupt_at:
                data = bytes(rec.typestore.serialize_cdr(scan_msg(rec, t, ranges), LASER_SCAN))
                rec.write_raw(TOPICS.scan, LASER_SCAN, t, data[:30])
            else:
                rec.write_message(TOPICS.scan, LASER_SCAN, t, scan_msg(rec, t, ranges))
    return path


GOOD = [1.0] * 21


def test_missing_and_unreadable_bags(tmp_path, capsys):
    code, _, err = run(
        capsys, "replay", tmp_path / "nope", "--method", "dwa1", "--out", tmp_path / "o"
    )
    assert code == 2 and f"{tmp_path / 'nope'}: no such bag" in error_line(err)

    (tmp_path / "junk.bag").write_bytes(b"not a bag at all")
    code, _, err = run(
        capsys, "replay", tmp_path / "junk.bag", "--method", "dwa1", "--out", tmp_path / "o"
    )
    assert code == 2 and f"{tmp_path / 'junk.bag'}: cannot open bag" in error_line(err)
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"].startswith("failed:") and summary["replayed"] == 0


def test_bag_without_laser_scan(tmp_path, capsys):
    write_bag(tmp_path / "bag", scans=None)
    code, _, err = run(
        capsys, "replay", tmp_path / "bag", "--method", "dwa1", "--out", tmp_path / "o"
    )
    line = error_line(err)
    assert code == 2 and str(tmp_path / "bag") in line
    assert "no usable sensor_msgs/msg/LaserScan topic" in line and TOPICS.odometry in line


def test_zero_beam_and_all_invalid_scans_replay_nothing_but_say_why(tmp_path, capsys):
    scans = [[], [np.nan] * 21, [0.0, -np.inf, 20.0, np.nan, np.inf], []]
    write_bag(tmp_path / "bag", scans)
    code, out, err = run(
        capsys,
        "replay",
        tmp_path / "bag",
        "--method",
        "dwa1",
        "--out",
        tmp_path / "o",
        "--json",
        "--no-plots",
    )
    line = error_line(err)
    assert code == 2 and str(tmp_path / "bag") in line and repr(TOPICS.scan) in line
    assert "2 all beams invalid" in line and "2 zero beams" in line
    assert json.loads(out)["skipped"] == {"zero beams": 2, "all beams invalid": 2}
    assert read_rows(tmp_path / "o" / "replay.csv") == []  # header only, but written
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["status"] == "complete"


def test_odometry_starting_after_the_last_scan(tmp_path, capsys):
    write_bag(tmp_path / "bag", [GOOD] * 3, odometry_steps=range(5, 9))
    code, _, err = run(
        capsys, "replay", tmp_path / "bag", "--method", "dwa1", "--out", tmp_path / "o"
    )
    line = error_line(err)
    assert code == 2 and "3 before first odometry sample" in line
    assert "no scan overlaps the odometry" in line and TOPICS.odometry in line


def test_a_corrupt_scan_is_skipped_and_the_rest_replayed(tmp_path, capsys):
    write_bag(tmp_path / "bag", [GOOD] * 5, corrupt_at=3)
    code, out, err = run(
        capsys,
        "replay",
        tmp_path / "bag",
        "--method",
        "dwa3",
        "--out",
        tmp_path / "o",
        "--json",
        "--no-plots",
    )
    assert code == 0, err
    summary = json.loads(out)
    assert (summary["scans"], summary["replayed"], summary["skipped"]) == (
        5,
        4,
        {"corrupt message": 1},
    )
    assert any(TOPICS.scan in note and "corrupt" in note for note in summary["notes"])


def test_only_some_topics(tmp_path, capsys):
    write_bag(tmp_path / "nogoal", [GOOD] * 3, goal=None)
    code, _, err = run(
        capsys, "replay", tmp_path / "nogoal", "--method", "dwa1", "--out", tmp_path / "o1"
    )
    assert code == 2 and "no goal" in error_line(err) and TOPICS.goal in err and "--goal X,Y" in err
    code, out, err = run(
        capsys,
        "replay",
        tmp_path / "nogoal",
        "--method",
        "dwa1",
        "--out",
        tmp_path / "o2",
        "--goal",
        "2,0",
        "--no-plots",
    )
    assert code == 0 and "replayed: 3" in out

    write_bag(tmp_path / "scanonly", [GOOD] * 3, odometry_steps=range(0))
    code, _, err = run(
        capsys, "replay", tmp_path / "scanonly", "--method", "dwa1", "--out", tmp_path / "o3"
    )
    line = error_line(err)
    assert (
        code == 2
        and "no odometry" in line
        and TOPICS.odometry in line
        and TOPICS.wheel_odometry in line
    )


def test_a_failure_halfway_keeps_the_rows_so_far(recorded_bag, tmp_path, capsys, monkeypatch):
    real_make_step_fn = transfer_bridge.make_step_fn

    def make_step_fn(method, policy, **_):
        inner = real_make_step_fn(method, policy)
        calls = []

        def step(s: ScanStep):
            if len(calls) == 5:
                raise FloatingPointError("planner blew up")
            calls.append(s)
            return inner(s)

        return step

    monkeypatch.setattr(transfer_bridge, "make_step_fn", make_step_fn)
    code, _, err = run(
        capsys, "replay", recorded_bag, "--method", "dwa2", "--out", tmp_path / "o", "--no-plots"
    )
    line = error_line(err)
    assert code == 2 and str(recorded_bag) in line and "FloatingPointError: planner blew up" in line
    assert len(read_rows(tmp_path / "o" / "replay.csv")) == 5
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"].startswith("failed: FloatingPointError") and summary["replayed"] == 5


def test_a_bag_that_breaks_off_is_replayed_up_to_the_break(recorded_bag, tmp_path, monkeypatch):
    from rosbags.highlevel import AnyReader

    original = AnyReader.messages

    def breaking(self, *args, **kwargs):
        for n, item in enumerate(original(self, *args, **kwargs)):
            if n == 60:
                raise OSError("unexpected end of chunk")
            yield item

    monkeypatch.setattr(AnyReader, "messages", breaking)
    result = replay_bag(recorded_bag, step_fn=transfer_bridge.make_step_fn("dwa2"))
    assert 0 < result.replayed < 20
    assert any(
        "reading stopped after" in n and "unexpected end of chunk" in n for n in result.notes
    )


def test_non_finite_odometry_is_a_corrupt_message(tmp_path):
    with BagRecorder(tmp_path / "bag", goal=(2.0, 0.0)) as rec:
        for k in range(1, 6):
            t = k * 100 * MS
            twist = (np.nan, 0.0) if k == 3 else (0.0, 0.0)
            rec.write_odometry(t, (0.0, 0.0, 0.0), twist)
            rec.write_scan(t, LaserScan(-1.0, 0.1, np.ones(21), 0.05, 10.0, t))
    result = replay_bag(tmp_path / "bag", step_fn=transfer_bridge.make_step_fn("dwa1"))
    assert result.replayed == 5  # scan 3 takes the pose interpolated from its neighbours
    assert f"{TOPICS.odometry}: 1 corrupt message(s) skipped" in result.notes


def test_a_non_finite_estimate_skips_the_scan():
    step = transfer_bridge.make_step_fn("dwa1")
    scan = LaserScan(-1.0, 0.1, np.ones(21), 0.05, 10.0)
    mount = Pose2D(0.156, 0.0, 0.0)
    bad = ScanStep(0, scan, mount, np.array([0.0, np.nan, 0.0]), np.zeros(2), np.array([2.0, 0.0]))
    with pytest.raises(SkipScan, match="non-finite"):
        step(bad)


def test_open_space_scans_are_replayed_broken_ones_are_not(tmp_path):
    """+inf is REP-117 'no return within range': a scan of (mostly) +inf is open space, and
    the simulator decides on it, so the replay must too; NaN / 0 / -inf carry nothing."""
    inf, nan = np.inf, np.nan
    scans = [[inf] * 21, [inf] * 19 + [nan, 0.0], [nan] * 19 + [inf, inf]]
    write_bag(tmp_path / "bag", scans)
    result = replay_bag(tmp_path / "bag", step_fn=transfer_bridge.make_step_fn("dwa1"))
    assert result.replayed == 2 and result.skipped == {"all beams invalid": 1}
    for row in result.rows:
        np.testing.assert_array_equal(row.observation[4:], 1.0)
