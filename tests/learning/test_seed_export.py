"""Issue 79's bad input for new training seeds: a seed whose run directory already holds it is
refused unless resumed, and ``--export DIR`` onto a ``DIR/seed-<k>/`` holding another run's
policy is refused before anything trains (one line, exit 2, through the command line)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.controllers import default_policy_path
from tests.learning.test_training import TINY_WORLD, _config
from tests.support.cli import refused


@pytest.fixture
def config(tmp_path: Path) -> Path:
    world = tmp_path / "tiny.yaml"
    world.write_text(TINY_WORLD)
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(_config(str(world), total_steps=30).to_dict()))
    return path


def _train(config: Path, seeds: str, out: Path, *extra: object) -> list[str]:
    return ["train", "--config", str(config), "--seeds", seeds, "--out", str(out), "--no-progress",
            *map(str, extra)]  # fmt: skip


def test_a_seed_already_in_the_directory_is_refused_unless_resumed(config, tmp_path, capsys):
    out = tmp_path / "runs"
    assert main(_train(config, "0", out)) == 0
    before = (out / "seed-0" / "summary.json").read_text()
    line = refused(capsys, *_train(config, "0,1", out))
    assert line == (
        f"d3dwa: error: {out / 'seed-0'} already holds a training run; continue with --resume or "
        "choose another --out"
    )
    assert not (out / "seed-1").exists()  # refused before any seed trained
    assert (out / "seed-0" / "summary.json").read_text() == before
    assert main(_train(config, "1", out)) == 0  # a new seed beside it is fine
    assert main(_train(config, "0,1", out, "--resume")) == 0
    assert "seed 0: already complete" in capsys.readouterr().out


def test_export_onto_another_runs_seed_is_refused_before_training(config, tmp_path, capsys):
    shipped = default_policy_path("d3dwa") / "seed-0"
    trained_in = json.loads((shipped / "summary.json").read_text())["run_dir"]
    export = tmp_path / "recipe-seeds" / "d3dwa"
    shutil.copytree(shipped, export / "seed-0")  # a shipped seed copied beside the new ones
    out = tmp_path / "runs"
    line = refused(capsys, *_train(config, "0,1", out, "--export", export))
    assert line == (
        f"d3dwa: error: --export: {export / 'seed-0'} already holds another run's policy (trained "
        f"in {trained_in}), not {out / 'seed-0'}'s; export elsewhere, or move that folder away first"
    )
    assert not out.exists() and not (export / "seed-1").exists()
    # a folder of other files is not replaced either
    (export / "seed-1").mkdir()
    (export / "seed-1" / "notes.txt").write_text("mine")
    line = refused(capsys, *_train(config, "1", out, "--export", export))
    assert f"{export / 'seed-1'} already holds other files" in line
    # a new seed exports; resumed, it exports again over its own export; another run may not
    assert main(_train(config, "2", out, "--export", export)) == 0
    assert json.loads((export / "seed-2" / "summary.json").read_text())["status"] == "done"
    assert main(_train(config, "2", out, "--export", export, "--resume")) == 0
    line = refused(capsys, *_train(config, "2", tmp_path / "other", "--export", export))
    assert f"already holds another run's policy (trained in {out / 'seed-2'})" in line
    assert (export / "seed-0" / "weights.pt").read_bytes() == (shipped / "weights.pt").read_bytes()
