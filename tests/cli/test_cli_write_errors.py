"""A file system that refuses a write (here the file-size limit, RLIMIT_FSIZE, standing in for
a full disk) ends eval, train, calibrate and export in one ``d3dwa: error:`` line naming the
path and the reason, exit 2, and what they had written before is still whole."""

from __future__ import annotations

import errno
import hashlib
from pathlib import Path

import pytest
import yaml

from tests.conftest import ONE_SECOND_WORLD
from tests.support.cli import run
from tests.support.file_limit import error_lines, run_d3dwa_with_file_limit
from transfer.calibrate_synthetic import SyntheticRun, write_calibration_bag

TOO_LARGE = "cannot write: File too large"


def digests(directory: Path) -> dict[str, str]:
    """Every file under directory -> the SHA-256 of its bytes."""
    return {
        str(p.relative_to(directory)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(directory.rglob("*"))
        if p.is_file()
    }


def refused_past_limit(argv: list[object], limit: int) -> str:
    done = run_d3dwa_with_file_limit(argv, limit)
    lines = error_lines(done.stderr)
    assert done.returncode == 2 and len(lines) == 1, (done.returncode, done.stderr)
    assert lines[0].startswith("d3dwa: error: ") and "Traceback" not in done.stderr
    return lines[0]


def no_temporaries(directory: Path) -> bool:
    return not [p for p in directory.rglob("*") if ".tmp" in p.name]


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    return path


def test_eval_keeps_its_rows_and_logs_when_a_log_cannot_be_written(tmp_path, tiny, capsys):
    out = tmp_path / "results"
    # random: a fixed method's noise-free episode would not run again at a second seed
    argv = ["eval", "--methods", "random", "--worlds", tiny, "--workers", "1", "--out", out]
    assert run(capsys, *argv, "--seeds", "1")[0] == 0
    before = digests(out)
    # meta.json is ~1.5 kB, a log ~5 kB
    line = refused_past_limit([*argv, "--seeds", "2"], limit=3000)
    assert line == f"d3dwa: error: {out / 'logs' / 'tiny__random__none__s1.npz'}: {TOO_LARGE}"
    after = digests(out)
    assert after["results.csv"] == before["results.csv"]
    assert after["logs/tiny__random__none__s0.npz"] == before["logs/tiny__random__none__s0.npz"]
    assert no_temporaries(out)


def test_train_keeps_its_checkpoints_when_a_new_one_cannot_be_written(tmp_path, tiny, capsys):
    config = tmp_path / "config.yaml"
    config.write_text(yaml.safe_dump({"method": "dqdwa", "worlds": [str(tiny)], "n_envs": 1,
                                      "eval_worlds": [str(tiny)], "keep": "final",
                                      "total_steps": 30}))  # fmt: skip
    out = tmp_path / "run"
    assert run(capsys, "train", "--config", config, "--out", out, "--no-progress")[0] == 0
    kept = {k: v for k, v in digests(out).items() if k.startswith(("policy/", "checkpoints/"))}
    argv = ["train", "--config", config, "--out", out, "--resume", "--total-steps", "60"]
    line = refused_past_limit([*argv, "--no-progress"], limit=20_000)  # the Q-table is 27 kB
    assert line.startswith(f"d3dwa: error: {out / 'checkpoints'}/") and line.endswith(TOO_LARGE)
    after = digests(out)
    assert {k: after.get(k) for k in kept} == kept
    assert no_temporaries(out)


def test_calibrate_keeps_the_profile_it_wrote_before(tmp_path, capsys):
    bag = tmp_path / "bag"
    write_calibration_bag(bag, run=SyntheticRun(drive_s=15.0))
    profile = tmp_path / "mine.yaml"
    assert run(capsys, "calibrate", bag, "--out", profile)[0] == 0
    before = profile.read_bytes()
    line = refused_past_limit(["calibrate", bag, "--out", profile, "--name", "other"], limit=500)
    assert line == f"d3dwa: error: {profile}: {TOO_LARGE}"
    assert profile.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "mine.yaml"]


def test_export_keeps_the_file_it_wrote_before(tmp_path, capsys):
    argv = ["export", "--onnx", tmp_path, "--method", "d3dwa", "--seeds", "0"]
    assert run(capsys, *argv)[0] == 0
    before = digests(tmp_path)
    line = refused_past_limit(argv, limit=10_000)  # the file is ~100 kB
    assert line == f"d3dwa: error: {tmp_path / 'd3dwa' / 'seed-0.onnx'}: {TOO_LARGE}"
    assert digests(tmp_path) == before


@pytest.mark.parametrize(
    ("error", "line"),
    [
        (OSError(errno.ENOSPC, "No space left on device", "/data/run/tb/events"),
         "d3dwa: error: /data/run/tb/events: No space left on device"),
        (OSError(errno.EFBIG, "File too large"), "d3dwa: error: File too large"),
        (FileExistsError(errno.EEXIST, "File exists", "/data/a", None, "/data/b"),
         "d3dwa: error: /data/a -> /data/b: File exists"),
    ],
)  # fmt: skip
def test_an_os_error_no_writer_named_is_still_one_line(capsys, monkeypatch, error, line):
    def fail(args):
        raise error

    monkeypatch.setattr("d3dwa_bullet.cli.worlds.cmd_worlds", fail)
    code, _, err = run(capsys, "worlds")
    assert code == 2 and err.splitlines() == [line]
