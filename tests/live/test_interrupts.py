"""A live run interrupted from outside, in real processes: Ctrl-C (SIGINT) in ``d3dwa drive``,
and the served robot killed mid-run. Either way the robot is sent a stop (or the connection
is known lost), the exit is one line, and the recorded bag is complete and readable."""

from __future__ import annotations

import re
import signal
import subprocess
from pathlib import Path

import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from tests.support.hang_guard import within  # noqa: E402
from tests.support.serve_process import D3DWA, start_serve  # noqa: E402
from transfer.bag_reader import read_bag  # noqa: E402


def start_drive(address: str, bag: Path) -> subprocess.Popen:
    """``d3dwa drive`` (paced by the wall clock), recording to bag."""
    return subprocess.Popen(
        [*D3DWA, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3",
         "--record", str(bag), "--watchdog", "5", "--timeout", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip


def wait_for_steps(drive: subprocess.Popen, step: int) -> list[str]:
    """Read drive's progress lines until it reports ``step``; returns them."""
    assert drive.stderr is not None
    lines = []
    while True:
        line = drive.stderr.readline()
        assert line, f"drive ended early: {''.join(lines)}"
        lines.append(line)
        if line.startswith(f"step {step}:"):
            return lines


def steps_in_bag(bag: Path, stopped: bool) -> int:
    """Scans in the bag, which must hold a command per scan, and the final stop if one was
    acknowledged."""
    data = read_bag(bag)  # readable: the writer closed it
    assert data.cmd_vel is not None
    assert data.cmd_vel.t_ns.size == len(data.scans) + stopped
    if stopped:
        assert tuple(data.cmd_vel.values[-1]) == (0.0, 0.0)
    return len(data.scans)


def test_ctrl_c_stops_the_robot_and_keeps_the_bag(tmp_path):
    bag = tmp_path / "interrupted"
    with within(120):
        serve, address = start_serve("--realtime")
        try:
            drive = start_drive(address, bag)
            wait_for_steps(drive, 10)
            drive.send_signal(signal.SIGINT)
            _, err = drive.communicate()
        finally:
            serve.send_signal(signal.SIGINT)
            served, _ = serve.communicate()
    last = err.strip().splitlines()[-1]
    assert drive.returncode == 130, err
    found = re.fullmatch(
        r"d3dwa: interrupted; the robot was stopped after (\d+) commands; "
        rf"{re.escape(str(bag))} keeps \d+ messages",
        last,
    )
    assert found, last
    assert steps_in_bag(bag, stopped=True) == int(found[1])
    assert serve.returncode == 0  # serve ends cleanly on Ctrl-C, and saw the stop last
    assert "the last asked for v 0 m/s, w 0 rad/s" in served


def test_a_killed_robot_ends_the_run_with_one_line_and_a_readable_bag(tmp_path):
    bag = tmp_path / "lost"
    with within(120):
        serve, address = start_serve("--realtime")
        try:
            drive = start_drive(address, bag)
            wait_for_steps(drive, 10)
        finally:
            serve.kill()
            serve.wait()
        _, err = drive.communicate()
    lines = err.strip().splitlines()
    assert drive.returncode == 2, err
    assert lines[-1].startswith("d3dwa: error: ") and "connection lost" in lines[-1], lines[-1]
    assert all(line.startswith("step ") for line in lines[:-1])  # no traceback
    found = re.search(
        r"the stop after (\d+) commands was not acknowledged \(connection lost\); "
        rf"{re.escape(str(bag))} keeps \d+ messages$",
        lines[-1],
    )
    assert found, lines[-1]
    assert steps_in_bag(bag, stopped=False) == int(found[1]) >= 10
