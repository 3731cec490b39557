"""A resumed ``d3dwa eval`` never writes through a symbolic link planted in its --out (as
results.csv, logs/ or the lock file): it is refused in one line, before any episode, and
the file or directory the link points to is left as it was."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

import d3dwa_bullet.episode as episode_module
from tests.conftest import ONE_SECOND_WORLD
from tests.support.cli import refused, run


@pytest.fixture
def evaluated(tmp_path: Path, capsys) -> tuple[Path, list[object]]:
    """A results directory of one finished episode, and the eval argv that extends it."""
    world = tmp_path / "tiny.yaml"
    world.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    out = tmp_path / "results"
    argv: list[object] = ["eval", "--methods", "dwa1", "--worlds", world, "--workers", "1"]
    assert run(capsys, *argv, "--seeds", "1", "--out", out)[0] == 0
    return out, [*argv, "--seeds", "2", "--out", out]


@pytest.fixture
def no_episode(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("an episode ran before the refusal")

    monkeypatch.setattr(episode_module, "run_episode", forbidden)
    monkeypatch.setattr("d3dwa_bullet.evaluation.jobs.run_episode", forbidden)


def test_a_results_csv_linked_out_of_out_is_not_appended_to(
    evaluated, tmp_path, capsys, no_episode
):
    out, argv = evaluated
    outside = tmp_path / "elsewhere.csv"
    outside.write_bytes((out / "results.csv").read_bytes())
    before = outside.read_bytes()
    (out / "results.csv").unlink()
    (out / "results.csv").symlink_to(outside)
    line = refused(capsys, *argv)
    assert f"{out / 'results.csv'}: is a symbolic link" in line
    assert outside.read_bytes() == before


def test_a_logs_directory_linked_out_of_out_is_not_written_into(
    evaluated, tmp_path, capsys, no_episode
):
    out, argv = evaluated
    outside = tmp_path / "elsewhere"
    (out / "logs").rename(outside)
    (out / "logs").symlink_to(outside)
    before = sorted(p.name for p in outside.iterdir())
    line = refused(capsys, *argv)
    assert f"{out / 'logs'} is a symbolic link" in line
    assert sorted(p.name for p in outside.iterdir()) == before


def test_a_lock_file_linked_out_of_out_is_not_overwritten(evaluated, tmp_path, capsys, no_episode):
    out, argv = evaluated
    outside = tmp_path / "precious.txt"
    outside.write_text("keep me\n")
    (out / ".d3dwa.lock").symlink_to(outside)
    line = refused(capsys, *argv)
    assert "lock file .d3dwa.lock: it is a symbolic link" in line
    assert outside.read_text() == "keep me\n"
