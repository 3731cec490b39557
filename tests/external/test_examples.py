"""The example packages of examples/: a follow-the-gap velocity planner that runs as an
external method by its class path, and (slow) installs by its entry point."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.params import RobotLimits
from d3dwa_bullet.world.registry import load_world
from tests.support.cli import run

ROOT = Path(__file__).resolve().parents[2]
FTG = ROOT / "examples" / "follow_the_gap"
NAME = "follow_the_gap.planner:FollowTheGap"


@pytest.fixture
def ftg_path(monkeypatch):
    monkeypatch.syspath_prepend(str(FTG))
    yield
    for module in ("follow_the_gap.planner", "follow_the_gap"):
        sys.modules.pop(module, None)


def test_follow_the_gap_drives_to_the_goal_within_the_limits(ftg_path):
    result = run_episode(load_world("R1"), make_controller(NAME))
    limits = RobotLimits()
    assert result.outcome == "goal", result.summary()
    assert np.abs(result.log["v_cmd"]).max() <= limits.v_max
    assert np.abs(result.log["w_cmd"]).max() <= limits.w_max
    assert np.isnan(result.log["wp"]).all() and (result.log["action"] == -1).all()
    assert result.summary()["method_source"].startswith(NAME)


def test_eval_prints_both_rows_and_the_reference(capsys, ftg_path, one_second_world, tmp_path):
    code, out, err = run(
        capsys, "eval", "--methods", f"dwa3,{NAME}", "--worlds", one_second_world,
        "--seeds", 2, "--workers", 1, "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 0, err
    assert "| DWA III (2,1,1) | fixed" in out and f"| {NAME} | external" in out
    assert "## Against the reference" in out and f"| {NAME} | `dwa3` |" in out


@pytest.mark.slow
@pytest.mark.parametrize(
    ("folder", "entry", "source"),
    [
        (FTG, "follow-the-gap", "follow_the_gap.planner:FollowTheGap (d3dwa-follow-the-gap 0.1.0)"),
        (ROOT / "examples" / "sb3_dqn", "sb3-dqn", "sb3_dqn.chooser:SB3DQN (d3dwa-sb3-dqn 0.1.0)"),
    ],
)
def test_the_example_installs_by_its_entry_point(tmp_path, folder, entry, source):
    """pip install into a fresh virtual environment (seeing this one's packages through a
    .pth file, so nothing is downloaded), then ``d3dwa methods`` and ``d3dwa run`` find it by
    name."""
    src = shutil.copytree(folder, tmp_path / "src")  # setuptools builds in the source tree
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)  # pip and setuptools: this environment's
    python = str(env_dir / "bin" / "python")
    own = subprocess.run(
        [python, "-c", "import site; print(site.getsitepackages()[0])"],
        check=True, capture_output=True, text=True, timeout=60,
    ).stdout.strip()  # fmt: skip
    # addsitedir, not a bare path: the host's own .pth files (the editable install) run too
    host = "".join(f"import site; site.addsitedir({d!r})\n" for d in site.getsitepackages())
    Path(own, "host.pth").write_text(host)
    subprocess.run(
        [python, "-m", "pip", "install", "-q", "--no-build-isolation", "--no-deps", str(src)],
        check=True, cwd=tmp_path, timeout=300,
    )  # fmt: skip
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # this checkout's code
    listed = subprocess.run(
        [python, "-m", "d3dwa_bullet.cli", "methods", "--json"],
        check=True, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    rows = {r["name"]: r for r in json.loads(listed.stdout)}
    assert rows[entry]["source"] == source
    ran = subprocess.run(
        [python, "-m", "d3dwa_bullet.cli", "run", "--world", "R1", "--method", entry, "--json"],
        check=True, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert json.loads(ran.stdout)["method_source"] == source
