"""The install carries everything it needs: packages, data folders, and the layering of pure code."""

from __future__ import annotations

import fnmatch
import importlib
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from d3dwa_bullet import resources
from d3dwa_bullet.cli import main
from d3dwa_bullet.errors import InstallError

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
SETUPTOOLS = PYPROJECT["tool"]["setuptools"]
#: Modules that must stay pure maths: no simulator, no network library.
PURE = (
    "d3dwa_bullet.planning.planner",
    "d3dwa_bullet.planning.observation",
    "d3dwa_bullet.planning.actions",
    "d3dwa_bullet.learning.reward",
    "d3dwa_bullet.episode_metrics",
    "d3dwa_bullet.episode_config",
    "d3dwa_bullet.sim.lidar_params",
    "d3dwa_bullet.evaluation.sweep_settings",
    "d3dwa_bullet.evaluation.stats",
    "d3dwa_bullet.evaluation.seed_stats",
    "d3dwa_bullet.geometry",
)


def _source_packages() -> set[str]:
    found = set()
    for top in ("d3dwa_bullet", "randomization", "transfer"):
        for init in (ROOT / top).rglob("__init__.py"):
            found.add(".".join(init.parent.relative_to(ROOT).parts))
    return found


def test_every_source_package_is_listed_for_the_wheel():
    listed = set(SETUPTOOLS["packages"])
    mapped = set(SETUPTOOLS["package-dir"])
    assert _source_packages() == listed - mapped


@pytest.mark.parametrize("package", sorted(PYPROJECT["tool"]["setuptools"]["package-dir"]))
def test_every_shipped_data_file_is_matched_by_package_data(package):
    folder = ROOT / SETUPTOOLS["package-dir"][package]
    patterns = SETUPTOOLS["package-data"][package]
    files = [
        p.relative_to(folder).as_posix()
        for p in folder.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".py"
    ]
    assert files, f"{folder} ships no data"
    missed = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert missed == []


@pytest.mark.parametrize("name", ["worlds", "urdf", "policies", "configs", "profiles", "barn"])
def test_data_folders_resolve_through_importlib_resources(name):
    path = resources.data_dir(name)
    assert path.is_dir() and any(path.iterdir())


def test_a_broken_install_names_the_missing_folder(monkeypatch, capsys):
    monkeypatch.setitem(resources._PACKAGES, "worlds", "d3dwa_bullet.data.no_such_folder")
    with pytest.raises(InstallError, match="worlds"):
        resources.worlds_dir()
    assert main(["worlds"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("d3dwa: error: ")
    assert "worlds/" in err[0] and "reinstall" in err[0]


def test_pure_layers_import_neither_pybullet_nor_torch():
    code = (
        "import sys\n"
        + "".join(f"import {m}\n" for m in PURE)
        + "print(sorted(m for m in ('pybullet', 'torch') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("package", sorted(_source_packages()))
def test_every_re_exported_name_resolves(package):
    module = importlib.import_module(package)
    missing = [n for n in getattr(module, "__all__", ()) if not hasattr(module, n)]
    assert missing == []


def test_ci_runs_exactly_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    commands = [line for line in readme.splitlines() if line.startswith("python3 -m venv .venv")]
    test_command = next(c for c in commands if c.endswith("python -m pytest -q"))
    main_job = next(c for c in commands if "d3dwa eval" in c)
    assert test_command in (ROOT / ".ci" / "run").read_text().splitlines()
    assert " -e " not in main_job  # the main job works from a plain install


@pytest.mark.skipif(not (ROOT / ".git").exists(), reason="not a git checkout")
@pytest.mark.parametrize(
    "made",
    [
        "build/lib/x.py",
        "examples/follow_the_gap/build/lib/x.py",
        "examples/sb3_dqn/build/x",
        "results_barn/table.md",
    ],
)
def test_what_the_readme_commands_leave_behind_is_ignored(made):
    """``pip install ./examples/...`` leaves build/ folders, the BARN command results_barn/."""
    found = subprocess.run(["git", "check-ignore", "-q", made], cwd=ROOT, check=False)
    assert found.returncode == 0, made
