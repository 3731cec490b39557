"""--backend on run, eval and sweep: bad values refused in one line, the backend named in every
row, and a results directory that never mixes two backends."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from tests.support.cli import refused, run


def rows(out: Path) -> list[dict[str, str]]:
    with (out / "results.csv").open(newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("command", ["run", "eval", "sweep"])
def test_an_unknown_backend_is_refused_before_anything_runs(
    capsys, tmp_path, one_second_world, command
):
    out = tmp_path / "out"
    base = {
        "run": ["run", "--world", one_second_world, "--method", "dwa3"],
        "eval": ["eval", "--worlds", one_second_world, "--methods", "dwa3", "--out", out],
        "sweep": ["sweep", "--worlds", one_second_world, "--methods", "dwa3", "--layouts", "0",
                  "--axes", "", "--profiles", "none", "--out", out],
    }[command]  # fmt: skip
    line = refused(capsys, *base, "--backend", "mujoco")
    assert line == "d3dwa: error: --backend 'mujoco': not one of pybullet, kinematic"
    assert not out.exists()


def test_gui_with_the_kinematic_backend_is_refused(capsys, one_second_world):
    line = refused(capsys, "run", "--world", one_second_world, "--method", "dwa3", "--gui",
                   "--backend", "kinematic")  # fmt: skip
    assert "--gui draws PyBullet's world; --backend kinematic has none to draw" in line


def test_run_names_the_backend_in_its_summary(capsys, one_second_world):
    code, out, _ = run(capsys, "run", "--world", one_second_world, "--method", "dwa3", "--json",
                       "--backend", "kinematic")  # fmt: skip
    assert code == 0 and json.loads(out)["backend"] == "kinematic"
    code, out, _ = run(capsys, "run", "--world", one_second_world, "--method", "dwa3", "--json")
    assert code == 0 and "backend" not in json.loads(out)  # PyBullet's rows keep their columns


def test_a_results_directory_never_mixes_backends(capsys, tmp_path, one_second_world):
    kin, ref = tmp_path / "kin", tmp_path / "ref"
    common = [
        "eval",
        "--worlds",
        one_second_world,
        "--methods",
        "dwa3,random",
        "--seeds",
        "2",
        "--workers",
        "1",
    ]
    code, _, err = run(capsys, *common, "--out", kin, "--backend", "kinematic")
    assert code == 0, err
    assert {r["backend"] for r in rows(kin)} == {"kinematic"} and len(rows(kin)) == 3
    before = (kin / "results.csv").read_bytes()
    line = refused(capsys, *common, "--out", kin)
    assert line == (
        f"d3dwa: error: {kin / 'results.csv'}: its episodes ran on --backend kinematic, this command "
        "has --backend pybullet; one directory never mixes backends: use another --out directory"
    )
    assert (kin / "results.csv").read_bytes() == before  # nothing a user made is lost
    code, _, err = run(capsys, *common, "--out", ref)
    assert code == 0, err
    assert "backend" not in rows(ref)[0]
    line = refused(capsys, *common, "--out", ref, "--backend", "kinematic")
    assert "its episodes ran on --backend pybullet, this command has --backend kinematic" in line
    # resumed on its own backend: nothing to run, the same rows
    code, _, err = run(capsys, *common, "--out", kin, "--backend", "kinematic")
    assert code == 0, err
    assert (kin / "results.csv").read_bytes() == before
