"""One writer per output directory (issue 24): a second eval, sweep or training into a directory
another process writes is refused in one line naming that process, before it writes anything;
a killed holder leaves no lock behind."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.dir_lock import LOCK_FILE, locked_dir
from d3dwa_bullet.errors import BusyError
from tests.conftest import ONE_SECOND_WORLD
from tests.support.cli import refused

HOLD = (
    "import sys, time\n"
    "from d3dwa_bullet.dir_lock import locked_dir\n"
    "with locked_dir(sys.argv[1]):\n"
    "    print('held', flush=True)\n"
    "    time.sleep(120)\n"
)


class Holder:
    """Another process holding the lock of a directory until it is killed."""

    def __init__(self, directory: Path) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", HOLD, str(directory)],
            stdout=subprocess.PIPE,
            text=True,
            env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)},
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()  # returns at 'held', or '' if the child died
        assert line == "held\n", f"the lock holder did not start (exit {self.proc.poll()})"

    @property
    def pid(self) -> int:
        return self.proc.pid

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=30)


@pytest.fixture
def hold() -> Iterator:
    holders: list[Holder] = []

    def start(directory: Path) -> Holder:
        holders.append(Holder(directory))
        return holders[-1]

    yield start
    for h in holders:
        h.kill()


def snapshot(directory: Path) -> dict[str, str]:
    """Every path under directory (dot files too) -> digest of its bytes ('' for a folder)."""
    return {
        str(p.relative_to(directory)): hashlib.sha256(p.read_bytes()).hexdigest()
        if p.is_file()
        else ""
        for p in sorted(directory.rglob("*"))
    }


def test_a_held_directory_is_refused_naming_the_holder(tmp_path, hold):
    holder = hold(tmp_path / "out")
    with pytest.raises(BusyError, match=rf"pid {holder.pid}\)"), locked_dir(tmp_path / "out"):
        pass


def test_a_killed_holder_leaves_no_lock(tmp_path, hold):
    out = tmp_path / "out"
    hold(out).kill()
    # SIGKILL: nothing removed the file, but the kernel dropped the lock
    assert (out / LOCK_FILE).exists()
    with locked_dir(out):
        assert (out / LOCK_FILE).read_text().split()[0] == str(os.getpid())
    assert not (out / LOCK_FILE).exists() and out.is_dir()


def test_the_lock_nests_in_one_process_and_leaves_the_directory_as_it_was(tmp_path):
    out = tmp_path / "new" / "out"
    with locked_dir(out):
        with locked_dir(out):  # a command's lock, then the library call's inside it
            assert (out / LOCK_FILE).exists()
        assert (out / LOCK_FILE).exists()  # the inner release did not free the outer hold
    assert not out.exists()  # created for the lock and left empty: removed again
    out.mkdir()
    (out / "results.csv").write_text("x\n")
    with locked_dir(out):
        pass
    assert [p.name for p in out.iterdir()] == ["results.csv"]


def test_a_second_eval_into_a_held_out_is_refused_before_it_writes(
    tmp_path, capsys, hold, one_second_world
):
    out = tmp_path / "out"
    argv = ["eval", "--worlds", one_second_world, "--methods", "dwa1", "--workers", "1"]
    assert main([*argv, "--out", str(out)]) == 0
    capsys.readouterr()
    rows = (out / "results.csv").read_bytes()
    holder = hold(out)
    before = snapshot(out)
    line = refused(capsys, *argv, "--out", out)
    assert line == (
        f"d3dwa: error: --out {out}: being written by another d3dwa command (pid "
        f"{holder.pid}); wait for it to end, or choose another --out"
    )
    assert snapshot(out) == before
    holder.kill()
    assert main([*argv, "--out", str(out)]) == 0  # the same eval again: resumed, no row twice
    assert (out / "results.csv").read_bytes() == rows
    assert not (out / LOCK_FILE).exists()


def no_layouts(*args, **kwargs):
    raise AssertionError("a layout was generated for a sweep into a held directory")


def test_a_second_sweep_into_a_held_out_is_refused_before_it_builds_layouts(
    tmp_path, capsys, hold, one_second_world, monkeypatch
):
    monkeypatch.setattr("d3dwa_bullet.evaluation.sweep.generate_world", no_layouts)
    out = tmp_path / "sweep"
    holder = hold(out)
    line = refused(capsys, "sweep", "--worlds", one_second_world, "--styles", "R1-style", "--layouts", "1",
                   "--axes", "", "--profiles", "none", "--methods", "dwa1", "--out", out)  # fmt: skip
    assert f"pid {holder.pid}" in line
    assert snapshot(out) == {LOCK_FILE: snapshot(out)[LOCK_FILE]}  # nothing but the holder's lock


def no_training(*args, **kwargs):
    raise AssertionError("training started in a held directory")


@pytest.mark.parametrize("held", ["run", "run/seed-1"])
def test_a_training_into_a_held_directory_is_refused_before_it_writes(
    tmp_path, capsys, hold, monkeypatch, held
):
    monkeypatch.setattr("d3dwa_bullet.learning.training.trainer.Trainer.run", no_training)
    config = tmp_path / "config.yaml"
    world = tmp_path / "tiny.yaml"
    world.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    config.write_text(yaml.safe_dump({"method": "dqdwa", "worlds": [str(world)], "n_envs": 1,
                                      "eval_worlds": [str(world)], "keep": "final"}))  # fmt: skip
    holder = hold(tmp_path / held)
    before = snapshot(tmp_path / "run")
    argv = ["train", "--config", config, "--out", tmp_path / "run", "--no-progress"]
    if held == "run":
        line = refused(capsys, *argv)
        assert f"--out {tmp_path / 'run'}: being written by another d3dwa command" in line
        assert f"(pid {holder.pid})" in line
    line = refused(capsys, *argv[:-1], "--seeds", "0-2", "--no-progress")
    assert f"{tmp_path / held}: being written by another d3dwa command (pid {holder.pid})" in line
    assert snapshot(tmp_path / "run") == before  # not even seed-0 was started


def test_a_report_into_a_held_directory_is_refused(tmp_path, capsys, hold):
    out = tmp_path / "results"
    holder = hold(out)
    line = refused(capsys, "report", out)
    assert f"DIR {out}: being written by another d3dwa command (pid {holder.pid})" in line
    assert not (out / "report.md").exists()


def test_a_replay_into_a_held_out_is_refused_before_it_reads_the_bag(tmp_path, capsys, hold):
    out = tmp_path / "replay"
    holder = hold(out)
    line = refused(capsys, "replay", tmp_path / "no-such-bag", "--method", "dwa3", "--out", out)
    assert f"--out {out}: being written by another d3dwa command (pid {holder.pid})" in line
    assert snapshot(out) == {LOCK_FILE: snapshot(out)[LOCK_FILE]}
