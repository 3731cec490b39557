"""scripts/replay_bag.py: ``d3dwa replay`` with the shipped D3DWA and results/replay as
defaults, on a tiny bag written into tmp_path."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from d3dwa_bullet.planning.actions import ACTIONS_FULL
from scripts import replay_bag
from tests.support.bag_messages import scan_msg
from transfer.bag_writer import BagRecorder
from transfer.topics import LASER_SCAN, TopicMap

SCRIPT = Path(replay_bag.__file__)
MS = 1_000_000
SCANS = 4


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four scans at 100 ms, the robot at rest at the origin, a goal 2 m ahead, a wall at
    0.8-1.6 m on the left."""
    path = tmp_path_factory.mktemp("bag") / "tiny"
    ranges = [3.0] * 11 + [0.8 + 0.08 * k for k in range(10)]
    with BagRecorder(path, goal=(2.0, 0.0)) as rec:
        for k in range(1, SCANS + 1):
            t = k * 100 * MS
            rec.write_odometry(t, (0.0, 0.0, 0.0), (0.0, 0.0))
            rec.write_message(TopicMap().scan, LASER_SCAN, t, scan_msg(rec, t, ranges))
    return path


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_defaults_replay_the_bag_with_the_shipped_d3dwa(bag, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert replay_bag.run([str(bag)]) == 0
    out = capsys.readouterr().out
    assert f"bag: {bag}" in out and f"scans: {SCANS}, replayed: {SCANS}, skipped: none" in out
    results = tmp_path / "results" / "replay"
    summary = json.loads((results / "summary.json").read_text())
    assert (summary["status"], summary["replayed"], summary["goal"]) == ("complete", 4, [2.0, 0.0])
    rows = read_rows(results / "replay.csv")
    assert len(rows) == SCANS
    table = ACTIONS_FULL.table()
    for row in rows:  # a learned choice over the full action set, not a fixed method's -1
        action = int(row["action"])
        assert 0 <= action < len(table) and float(row["tau"]) == table[action, 3]
    for name in ("path", "sectors", "commands"):
        assert (results / f"{name}.png").stat().st_size > 0


def test_given_options_replace_the_defaults(bag, tmp_path, capsys):
    out_dir = tmp_path / "o"
    argv = [str(bag), "--method=dwa1", f"--out={out_dir}", "--json", "--no-plots"]
    assert replay_bag.run(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["replayed"], summary["skipped"]) == (SCANS, {})
    rows = read_rows(out_dir / "replay.csv")
    assert {(r["action"], r["wp"], r["wc"], r["ws"], r["tau"]) for r in rows} == {
        ("-1", "1.0", "1.0", "2.0", "4.0")
    }
    assert not (out_dir / "path.png").exists()


def test_runs_as_a_program_and_reports_errors_in_one_line(bag, tmp_path):
    def script(*argv: object) -> subprocess.CompletedProcess:
        command = [sys.executable, str(SCRIPT), *map(str, argv)]
        return subprocess.run(command, capture_output=True, text=True, timeout=300)

    done = script(bag, "--method", "dwa2", "--out", tmp_path / "o", "--no-plots")
    assert done.returncode == 0, done.stderr
    assert (
        f"replayed: {SCANS}" in done.stdout
        and f"wrote {tmp_path / 'o' / 'replay.csv'}" in done.stdout
    )
    missing = script(tmp_path / "nope", "--out", tmp_path / "o2")
    # pybullet prints its build time on stderr when it loads; besides it, one error line.
    lines = [x for x in missing.stderr.splitlines() if not x.startswith("pybullet build time")]
    assert missing.returncode == 2
    assert lines == [f"d3dwa: error: {tmp_path / 'nope'}: no such bag (file or directory)"]
