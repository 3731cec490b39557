"""``d3dwa calibrate`` end to end: text and ``--json`` output, the never-still note, and bad input
(no LaserScan, too few scans, unreadable bags, bad --out or --base): exactly one
``d3dwa: error:`` line, exit 2, and no profile (or temporary) file left behind."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.sim.scan import LaserScan
from randomization.profiles import load_profile
from transfer.bag_writer import BagRecorder
from transfer.calibrate_synthetic import SyntheticRun, write_calibration_bag
from transfer.calibration import HEADER
from transfer.topics import TopicMap


def run(capsys: pytest.CaptureFixture, *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def refused(capsys: pytest.CaptureFixture, out_dir: Path, *argv: object) -> str:
    """Expect exit 2, one ``d3dwa: error:`` line, and nothing written into out_dir."""
    before = {p.name for p in out_dir.iterdir()}
    code, _, err = run(capsys, *argv)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("d3dwa: error: "), (code, err)
    assert {p.name for p in out_dir.iterdir()} == before
    return lines[0]


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cli") / "bag"
    write_calibration_bag(path, run=SyntheticRun(drive_s=15.0))
    return path


def test_json_names_profile_scans_estimated_and_kept(capsys, bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "my_robot.yaml"
    code, stdout, err = run(capsys, "calibrate", bag, "--out", out, "--json")
    assert code == 0 and err == ""
    data = json.loads(stdout)
    assert set(data) == {"profile", "scans", "estimated", "kept_from_base"}
    assert data["profile"] == str(out) and data["scans"] == 180
    assert "lidar.range_std" in data["estimated"] and "latency.steps" in data["kept_from_base"]
    assert load_profile(out).sample(np.random.default_rng(0)).lidar.range_std > 0


def test_text_output_and_other_topic_names(capsys, tmp_path: Path) -> None:
    topics = TopicMap(scan="/front/scan", odometry="/odom", wheel_odometry=None, imu=None)
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(drive_s=4.0, topics=topics))
    out = tmp_path / "p.yaml"
    code, stdout, _ = run(capsys, "calibrate", tmp_path / "b", "--out", out, "--name", "mine")
    assert code == 0
    assert stdout.splitlines()[0].startswith(f"wrote {out} (")
    assert f"use it with: --noise {out}" in stdout
    assert load_profile(out).name == "mine"


def test_explicit_topic_override(capsys, tmp_path: Path) -> None:
    topics = TopicMap(scan="/a/scan", odometry="/odom", wheel_odometry="/wheel", imu=None)
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(drive_s=4.0, topics=topics))
    code, stdout, _ = run(
        capsys, "calibrate", tmp_path / "b", "--out", tmp_path / "p.yaml", "--json",
        "--topic", "odometry=/odom", "--topic", "wheel_odometry=/wheel",
    )  # fmt: skip
    assert code == 0 and "odometry.track_error_std" not in json.loads(stdout)["estimated"]
    # 4 s of driving is too short for the geometry fit: kept, with the reason in the file
    assert (
        "need 1.0 m" in (tmp_path / "p.yaml").read_text()
        or "turned" in (tmp_path / "p.yaml").read_text()
    )


def test_never_standing_still_is_a_note_not_an_error(capsys, tmp_path: Path) -> None:
    topics = TopicMap(odometry="/odom", wheel_odometry=None, imu=None)
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(still_s=0.0, drive_s=4.0, topics=topics))
    code, stdout, err = run(capsys, "calibrate", tmp_path / "b", "--out", tmp_path / "p.yaml")
    notes = [line for line in stdout.splitlines() if line.startswith("note: ")]
    assert code == 0 and err == "" and len(notes) == 1
    assert "never stands still" in notes[0] and "line-fit" in notes[0]
    code, stdout, err = run(
        capsys, "calibrate", tmp_path / "b", "--out", tmp_path / "q.yaml", "--json"
    )
    assert json.loads(stdout)["profile"] == str(tmp_path / "q.yaml")
    assert err.startswith("note: ") and len(err.splitlines()) == 1


def test_bag_without_laserscan(capsys, tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "odom_only") as rec:
        for k in range(20):
            rec.write_odometry(10**9 + k * 10**8, (0.0, 0.0, 0.0), (0.0, 0.0))
    line = refused(
        capsys, tmp_path, "calibrate", tmp_path / "odom_only", "--out", tmp_path / "p.yaml"
    )
    assert "no usable sensor_msgs/msg/LaserScan topic" in line


def test_too_few_scans_says_how_many(capsys, tmp_path: Path) -> None:
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(still_s=0.3, drive_s=0.3))
    line = refused(capsys, tmp_path, "calibrate", tmp_path / "b", "--out", tmp_path / "p.yaml")
    assert "5 scan(s)" in line and "at least 10 scans" in line


def test_no_stillness_and_no_lines_is_an_error(capsys, tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    topics = TopicMap(odometry="/odom", wheel_odometry=None, imu=None)
    with BagRecorder(tmp_path / "b", topics=topics) as rec:
        for k in range(20):  # moving, and every other beam invalid: no triple of valid beams
            t = 10**9 + k * 10**8
            r = np.where(np.arange(100) % 2 == 0, rng.uniform(1, 3, 100), np.inf)
            rec.write_odometry(t, (0.02 * k, 0.0, 0.0), (0.2, 0.0))
            rec.write_scan(t, LaserScan(-1.0, 0.02, r, 0.05, 10.0, t))
    line = refused(capsys, tmp_path, "calibrate", tmp_path / "b", "--out", tmp_path / "p.yaml")
    assert "need 5, i.e. 6 consecutive scans standing still" in line and "line fits" in line


@pytest.mark.parametrize("kind", ["garbage", "missing", "empty_dir"])
def test_unreadable_bag(capsys, tmp_path: Path, kind: str) -> None:
    target = tmp_path / "x.bag"
    if kind == "garbage":
        target.write_bytes(b"\x00not a bag\xff" * 10)
    elif kind == "empty_dir":
        target = tmp_path / "dir"
        target.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    line = refused(capsys, out, "calibrate", target, "--out", out / "p.yaml")
    assert str(target) in line


def test_one_bad_bag_among_good_ones_writes_nothing(capsys, bag: Path, tmp_path: Path) -> None:
    line = refused(
        capsys, tmp_path, "calibrate", bag, tmp_path / "nope", "--out", tmp_path / "p.yaml"
    )
    assert "nope" in line


@pytest.mark.parametrize(
    "out, base, needle",
    [
        ("p.txt", "real", "must end in .yaml"),
        ("missing/p.yaml", "real", "does not exist"),
        ("p.yaml", "realistic", "unknown profile 'realistic'"),
    ],
)
def test_bad_out_or_base(
    capsys, bag: Path, tmp_path: Path, out: str, base: str, needle: str
) -> None:
    line = refused(capsys, tmp_path, "calibrate", bag, "--out", tmp_path / out, "--base", base)
    assert needle in line


def test_existing_profile_is_replaced_only_on_success(capsys, bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "p.yaml"
    old = f"{HEADER} from 1 bag(s), 9 scans:\nold\n"  # an earlier run's profile
    out.write_text(old)
    refused(capsys, tmp_path, "calibrate", tmp_path / "nope", "--out", out)
    assert out.read_text() == old
    code, _, _ = run(capsys, "calibrate", bag, "--out", out)
    assert code == 0 and load_profile(out).name == "p"


def test_a_file_calibrate_did_not_write_is_not_replaced_without_force(
    capsys, bag: Path, tmp_path: Path
) -> None:
    config = tmp_path / "d3dwa.yaml"
    config.write_text("method: d3dwa\ntotal_steps: 1000\n")  # the user's training config
    line = refused(capsys, tmp_path, "calibrate", bag, "--out", config)
    assert "is not a profile written by `d3dwa calibrate`" in line and "--force" in line
    assert config.read_text() == "method: d3dwa\ntotal_steps: 1000\n"
    code, _, _ = run(capsys, "calibrate", bag, "--out", config, "--force")
    assert code == 0 and load_profile(config).name == "d3dwa"
    code, _, _ = run(capsys, "calibrate", bag, "--out", config)  # its own profile: replaced
    assert code == 0


def test_a_special_file_as_out_is_refused_even_with_force(capsys, bag: Path, tmp_path: Path):
    link = tmp_path / "null.yaml"
    link.symlink_to("/dev/null")
    line = refused(capsys, tmp_path, "calibrate", bag, "--out", link, "--force")
    assert "is not a regular file" in line
    assert link.is_symlink()


def test_a_bag_name_cannot_inject_yaml_into_the_profile(capsys, tmp_path: Path) -> None:
    evil = tmp_path / "bag\nparams: {}\nname: pwned\n#.bag"  # a ROS 1 bag file
    write_calibration_bag(evil, run=SyntheticRun(drive_s=4.0))
    out = tmp_path / "p.yaml"
    code, _, _ = run(capsys, "calibrate", evil, "--out", out)
    assert code == 0
    text = out.read_text()
    assert "name: pwned" not in text.splitlines()
    assert [ln for ln in text.splitlines() if ln.startswith("#   ")] == [
        f"#   {tmp_path}/bag\\nparams: {{}}\\nname: pwned\\n#.bag"
    ]
    assert load_profile(out).name == "p"
