"""``d3dwa drive``: what it refuses (one line, exit 2, a stop wherever a connection existed),
and ``--record``, whose bag ``d3dwa replay`` and ``compare-scans`` read."""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.episode import EpisodeConfig  # noqa: E402
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint  # noqa: E402
from d3dwa_bullet.learning.agents.onnx_export import export_onnx  # noqa: E402
from d3dwa_bullet.planning.actions import ACTIONS_FULL  # noqa: E402
from d3dwa_bullet.planning.observation_kinds import observation_layout  # noqa: E402
from d3dwa_bullet.resources import policies_dir  # noqa: E402
from d3dwa_bullet.sim.lidar import LidarParams  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import refused, run  # noqa: E402
from transfer.bag_reader import read_bag  # noqa: E402

PATIENT = ("--lockstep", "--watchdog", "60", "--timeout", "30")


def drive_args(address: str, *extra: str) -> tuple[str, ...]:
    return ("drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3", *PATIENT, *extra)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_was_sent(sim) -> bool:
    """The last velocity request the server saw is a zero one."""
    return bool(sim.requests) and sim.requests[-1][:2] == (0.0, 0.0)


def test_unreachable_robot_is_one_line_and_nothing_sent(capsys, tmp_path):
    port = free_port()
    bag = tmp_path / "never"
    args = drive_args(f"127.0.0.1:{port}", "--connect-timeout", "0.5", "--record", str(bag))
    line = refused(capsys, *args)
    assert f"cannot reach a Kachaka at 127.0.0.1:{port} within 0.5 s" in line
    assert line.endswith("nothing was sent; no bag written") and not bag.exists()


def test_another_api_version_is_refused_with_a_stop(capsys, serve):
    sim, address = serve(load_world("R1"), version="2.9.0")
    line = refused(capsys, *drive_args(address))
    assert "runs Kachaka API version '2.9.0'" in line and "robot was stopped" in line
    assert sim.received == [] and stop_was_sent(sim)


def test_a_robot_without_a_scan_is_refused_with_a_stop(capsys, serve):
    sim, address = serve(load_world("R1"), serve_scan=False)
    line = refused(capsys, *drive_args(address))
    assert "serves no laser scan" in line
    assert sim.received == [] and stop_was_sent(sim)


def test_a_goal_outside_the_served_map_is_refused_with_a_stop(capsys, serve):
    sim, address = serve(load_world("R1"))
    args = list(drive_args(address))
    args[args.index("--goal") + 1] = "40,0"
    code, _, err = run(capsys, *args)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "--goal 40,0 lies outside the robot's map 'R1'" in err
    assert sim.received == [] and stop_was_sent(sim)


def test_a_narrower_scan_than_the_policy_reads_is_refused(capsys, serve):
    narrow = EpisodeConfig(lidar=LidarParams(fov=math.radians(180.0)))
    sim, address = serve(load_world("R1"), config=narrow)
    line = refused(capsys, *drive_args(address))
    assert "leaves observation sector(s) 0, 7 of 8" in line and "robot was stopped" in line
    assert sim.received == [] and stop_was_sent(sim)


def test_a_finer_scan_is_mapped_into_the_same_sectors(capsys, serve):
    fine = EpisodeConfig(lidar=LidarParams(fov=math.radians(270.0), increment=math.radians(0.25)))
    sim, address = serve(load_world("R1"), config=fine)
    code, out, err = run(capsys, *drive_args(address, "--json", "--time-limit", "2"))
    assert code == 0, err
    assert json.loads(out)["steps"] == 20 and len(sim.received) == 21  # 20 steps and the stop


def test_a_policy_of_another_observation_is_refused_before_connecting(capsys, tmp_path):
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(16,)), observation_layout("progress"))
    policy = save_checkpoint(tmp_path / "progress", agent, method="d3dwa")
    line = refused(
        capsys, "drive", "--kachaka", f"127.0.0.1:{free_port()}", "--goal", "3,0",
        "--method", "d3dwa", "--policy", str(policy),
    )  # fmt: skip
    assert "progress" in line and "paper" in line


def test_without_the_robot_extra_drive_says_what_to_install(capsys, monkeypatch):
    for name in [m for m in sys.modules if m.split(".")[0] in ("kachaka_api", "grpc")]:
        monkeypatch.setitem(sys.modules, name, None)  # importing it raises ImportError
    for name in [m for m in sys.modules if m.startswith("d3dwa_bullet.live")]:
        monkeypatch.delitem(sys.modules, name)
    line = refused(capsys, *drive_args("127.0.0.1:1"))
    assert 'pip install "d3dwa-bullet[robot]"' in line


def test_recorded_drive_replays_to_the_same_commands(capsys, serve, tmp_path):
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    bag = tmp_path / "live_bag"
    code, out, err = run(
        capsys,
        *drive_args(address, "--json", "--time-limit", "3", "--record", str(bag)),
        "--speed-limit",
        "0.4,2.0",  # replay does not clamp: the bag holds what was sent
    )
    assert code == 0, err
    steps = json.loads(out)["steps"]
    data = read_bag(bag)
    assert len(data.scans) == steps == 30
    code, out, err = run(
        capsys, "replay", str(bag), "--method", "dwa3", "--out", str(tmp_path / "replay"),
        "--no-plots", "--json",
    )  # fmt: skip
    assert code == 0, err
    summary = json.loads(out)
    assert summary["replayed"] == steps and summary["goal"] == [3.0, 0.0]
    rows = (tmp_path / "replay" / "replay.csv").read_text().splitlines()
    header = rows[0].split(",")
    values = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    cmd = values[:, [header.index("cmd_v"), header.index("cmd_w")]]
    recorded = values[:, [header.index("rec_cmd_v"), header.index("rec_cmd_w")]]
    np.testing.assert_array_equal(cmd, recorded)
    np.testing.assert_array_equal(cmd, np.asarray(sim.received[:steps]))
    code, out, err = run(capsys, "compare-scans", str(bag), str(bag), "--json")
    assert code == 0, err
    assert json.loads(out)["a"]["scans"] == steps


def test_refusals_come_before_the_heavy_imports():
    """Bad drive / serve input is refused before grpc, the simulator or torch is imported."""
    script = (
        "import sys\nfrom d3dwa_bullet.cli.app import main\n"
        'for argv in (["drive", "--kachaka", "h", "--goal", "1", "--method", "dwa3"],'
        ' ["drive", "--kachaka", "h", "--goal", "1,2", "--method", "nope"],'
        ' ["drive", "--kachaka", "h", "--goal", "1,2", "--method", "dwa3",'
        ' "--speed-limit", "0,1"],'
        ' ["drive", "--kachaka", "h", "--goal", "1,2", "--method", "dwa3", "--stale", "0"],'
        ' ["serve", "--world", "R1", "--noise", "nope"]):\n'
        "    assert main(argv) == 2\n"
        "print([m for m in ('torch', 'pybullet', 'numba', 'grpc') if m in sys.modules])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
    assert done.stderr.count("d3dwa: error: ") == 5
    assert "--stale must be a number of seconds > 0, got 0" in done.stderr


def test_drive_with_an_onnx_policy_never_imports_torch(tmp_path):
    onnx = export_onnx(policies_dir() / "d3dwa" / "seed-0", tmp_path / "d3dwa.onnx").file
    script = (
        "import sys\nfrom d3dwa_bullet.cli.app import main\n"
        f"code = main(['drive', '--kachaka', '127.0.0.1:{free_port()}', '--goal', '3,0', "
        f"'--method', 'd3dwa', '--onnx', {str(onnx)!r}, '--connect-timeout', '0.3'])\n"
        "print(code, 'torch' in sys.modules, 'onnxruntime' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    *said, last = done.stdout.splitlines()
    assert last.split() == ["2", "False", "True"], done.stderr
    # the operator is told what drives, before anything is sent
    (line,) = said  # then what the file recorded: its decision period and recovery layer
    assert line.startswith(f"policy: {onnx} (ONNX, exported for d3dwa)")
    assert "cannot reach a Kachaka" in done.stderr  # it got as far as connecting
