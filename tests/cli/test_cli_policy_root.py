"""``--policy-root DIR`` on eval and sweep: each learned method's seed folders from
``DIR/<method>/seed-<k>/``, recorded in meta.json, a resumed run with another root refused,
and its bad input one line before any episode."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.cli.options import default_methods
from d3dwa_bullet.evaluation.policy_runs import method_runs
from d3dwa_bullet.evaluation.sweep import read_sweep
from tests.cli.test_sweep_plan import PLAN
from tests.conftest import ONE_SECOND_WORLD
from tests.evaluation.test_policy_runs import seed_folder
from tests.support.cli import refused

NEAR_GOAL = dict(ONE_SECOND_WORLD, name="near", goal=[0.3, 0.0], time_limit=10.0)


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> tuple[Path, Path]:
    """(a world file, a policy root holding d3dwa/seed-0, seed-1)."""
    base = tmp_path_factory.mktemp("root")
    world = base / "near.yaml"
    world.write_text(yaml.safe_dump(NEAR_GOAL))
    root = base / "recipe-seeds"
    seed_folder(root, seeds=(0, 1))
    (root / "d3dwa" / "seed-1" / "learning_curve.png").write_bytes(b"a curve")  # report copies it
    return world, root


def _eval(world: Path, root: Path, out: Path, *extra: str) -> list[str]:
    return ["eval", "--worlds", str(world), "--methods", "d3dwa", "--policy-root", str(root),
            "--workers", "1", "--out", str(out), *extra]  # fmt: skip


def _rows(out: Path) -> list[dict[str, str]]:
    with (out / "results.csv").open() as fh:
        return list(csv.DictReader(fh))


def test_runs_come_from_the_root_and_default_methods_follow_it(setup):
    _, root = setup
    runs = method_runs(["dwa3", "d3dwa"], None, None, str(root))
    assert [(r.method, r.policy_seed, r.policy) for r in runs] == [
        ("dwa3", None, None),
        ("d3dwa", 0, str(root / "d3dwa" / "seed-0")),
        ("d3dwa", 1, str(root / "d3dwa" / "seed-1")),
    ]
    learned = [m for m in default_methods(str(root)) if m.startswith(("d3dwa", "dqdwa"))]
    assert learned == ["d3dwa"]  # the root holds d3dwa alone; the shipped ones hold more
    assert "d3dwa-dr" in default_methods()


def test_eval_records_the_root_and_refuses_another_on_resume(setup, tmp_path, capsys):
    world, root = setup
    out = tmp_path / "res"
    assert main(_eval(world, root, out)) == 0
    assert [(r["method"], r["policy_seed"]) for r in _rows(out)] == [("d3dwa", "0"), ("d3dwa", "1")]
    settings = json.loads((out / "meta.json").read_text())["settings"]
    assert settings["policy_root"] == str(root.resolve())
    assert set(settings["policy_digests"]) == {"d3dwa/seed-0", "d3dwa/seed-1"}
    assert main(_eval(world, root, out)) == 0  # the same root resumes
    capsys.readouterr()
    # a copy of the root: the same weights, so the digests agree; the root itself refuses
    twin = tmp_path / "twin"
    shutil.copytree(root, twin)
    line = refused(capsys, *_eval(world, twin, out))
    assert f"its episodes ran with --policy-root '{root.resolve()}'" in line
    assert f"this command has '{twin.resolve()}'" in line
    # no root at all (the shipped policies) is another run too
    line = refused(capsys, "eval", "--worlds", world, "--methods", "d3dwa", "--out", out)
    assert f"its episodes ran with --policy-root '{root.resolve()}', this command has None" in line
    assert len(_rows(out)) == 2
    # the report shows the root's learning curves, not the shipped ones
    assert main(["report", str(out)]) == 0
    page = (out / "report.md").read_text()
    assert "(`recipe-seeds/d3dwa/seed-1/learning_curve.png`)" in page
    assert (out / "figures" / "learning_curve_d3dwa_seed-1.png").read_bytes() == b"a curve"
    assert "d3dwa-dr" not in page


def test_sweep_records_the_root(setup, tmp_path, capsys):
    world, root = setup
    out = tmp_path / "sweep"
    argv = ["sweep", "--methods", "d3dwa", "--worlds", str(world), "--layouts", "0", "--axes", "",
            "--profiles", "none", "--seeds", "1", "--workers", "1", "--policy-root", str(root),
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    assert sorted(r["policy_seed"] for r in read_sweep(out)) == [0, 1]
    settings = json.loads((out / "meta.json").read_text())["settings"]
    assert settings["policy_root"] == str(root.resolve())
    twin = tmp_path / "twin"
    shutil.copytree(root, twin)
    assert "--policy-root" in refused(capsys, *argv[:-4], "--policy-root", twin, "--out", out)


def test_a_plan_sweep_drives_the_roots_seeds(setup, tmp_path, capsys):
    _, root = setup
    plan = tmp_path / "plan.yaml"
    cells = [{"a": "d3dwa", "b": "dwa3", "question": "policies"}]
    plan.write_text(yaml.safe_dump(PLAN | {"cells": cells}))
    out = tmp_path / "plan"
    argv = ["sweep", "--methods", "d3dwa,dwa3", "--worlds", "", "--styles", "R1-style",
            "--layouts", "4", "--axes", "", "--profiles", "", "--seeds", "1", "--time-limit", "1",
            "--workers", "1", "--policy-root", str(root), "--out", str(out), "--plan", str(plan)]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    rows = read_sweep(out)
    assert {r["policy_seed"] for r in rows if r["method"] == "d3dwa"} == {0, 1}
    settings = json.loads((out / "meta.json").read_text())["settings"]
    assert settings["policy_root"] == str(root.resolve())


@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_bad_roots_are_one_line_before_any_episode(setup, tmp_path, capsys, command):
    world, root = setup
    out = tmp_path / "never"
    common = [command, "--worlds", world, "--out", out]
    missing = tmp_path / "nowhere"
    line = refused(capsys, *common, "--methods", "d3dwa", "--policy-root", missing)
    assert line == f"d3dwa: error: --policy-root {missing}: no such folder"
    line = refused(capsys, *common, "--methods", "dwa3,d3dwa-dr", "--policy-root", root)
    assert line == (
        f"d3dwa: error: --policy-root {root}: it has no folder d3dwa-dr/ for learned method "
        f"'d3dwa-dr' (expected {root / 'd3dwa-dr'}/seed-<k>/)"
    )
    line = refused(capsys, *common, "--methods", "d3dwa", "--policy-root", root,
                   "--policy", root / "d3dwa")  # fmt: skip
    assert line == (
        f"d3dwa: error: --policy-root {root} and --policy {root / 'd3dwa'} both say where "
        "policies are: give one"
    )
    assert not out.exists()
