"""Methods from outside the package on the command line: ``d3dwa methods``, ``run`` and
``eval`` with one, its source in every row, and the one-line refusals (exit 2)."""

from __future__ import annotations

import csv
import json
from importlib.metadata import EntryPoint

import pytest

from d3dwa_bullet.external import protocol
from tests.support.cli import refused, run

HERE = "tests.support.external_methods"


def _entry_points(monkeypatch, **points: str) -> None:
    found = {n: EntryPoint(n, v, protocol.ENTRY_POINT_GROUP) for n, v in points.items()}
    monkeypatch.setattr("d3dwa_bullet.external.resolve.entry_points_named", lambda: found)
    monkeypatch.setattr("d3dwa_bullet.method_specs.entry_points_named", lambda: found)
    monkeypatch.setattr("d3dwa_bullet.method_specs._EXTERNAL_SEEN", set())


def test_methods_lists_builtins_and_installed_ones_with_their_source(capsys, monkeypatch):
    _entry_points(monkeypatch, straight=f"{HERE}:Straight", dwa1=f"{HERE}:Straight")
    code, out, _ = run(capsys, "methods", "--json")
    rows = {r["name"]: r for r in json.loads(out)}
    assert code == 0 and rows["dwa3"]["source"] == "built-in"
    assert rows["straight"]["label"] == "velocity planner"
    assert rows["straight"]["source"].startswith(f"{HERE}:Straight in ")
    dwa1 = [r for r in json.loads(out) if r["name"] == "dwa1"]
    assert dwa1[0]["source"] == "built-in"  # never shadowed, and the installed one is refused
    assert dwa1[1]["label"] == "refused" and "never shadowed" in dwa1[1]["source"]


def test_run_names_the_source(capsys, one_second_world):
    code, out, _ = run(
        capsys, "run", "--world", one_second_world, "--method", f"{HERE}:Straight", "--json"
    )
    row = json.loads(out)
    assert code == 0 and row["steps"] == 10 and row["method_source"].startswith(f"{HERE}:Straight")


@pytest.mark.parametrize(
    ("method", "said"),
    [
        ("nowhere_pkg.mod:Thing", "module 'nowhere_pkg.mod' cannot be imported"),
        (f"{HERE}:RaisesAtConstruction", "raised at construction"),
        (f"{HERE}:TooFast", "beyond the robot's limits"),
        ("tests.support.exits_on_import:Planner", "cannot be imported: called sys.exit(0)"),
        (f"{HERE}:ExitsAtConstruction", "raised at construction: called sys.exit(0)"),
        (f"{HERE}:ExitsSevenAtConstruction", "raised at construction: called sys.exit(7)"),
        (f"{HERE}:ExitsOnFifthCommand", "command() raised at step 4: called sys.exit(0)"),
    ],
)
def test_run_refuses_a_method_that_cannot_be_trusted(capsys, one_second_world, method, said):
    line = refused(capsys, "run", "--world", one_second_world, "--method", method)
    assert method in line and said in line


def test_eval_rows_name_the_source_and_one_name_never_mixes_two(
    capsys, monkeypatch, one_second_world, tmp_path
):
    _entry_points(monkeypatch, mine=f"{HERE}:HeldRandom")
    out = tmp_path / "res"
    args = ("eval", "--methods", "dwa3,mine", "--worlds", one_second_world, "--workers", 1)
    code, _, err = run(capsys, *args, "--out", out)
    assert code == 0, err
    rows = list(csv.DictReader((out / "results.csv").open()))
    by_method = {r["method"]: r["method_source"] for r in rows}
    # the chooser's floors came with it: every step and held for its declared period
    assert set(by_method) == {"dwa3", "mine", "random", "random@10"}
    assert by_method["dwa3"] == "" and by_method["mine"].startswith(f"{HERE}:HeldRandom in ")
    table = (out / "table.md").read_text()
    assert "`random@10`" in table.split("Against chance")[1]
    _entry_points(monkeypatch, mine=f"{HERE}:HeldRandomToo")
    line = refused(capsys, *args, "--out", out)
    assert "method 'mine' came from" in line and "never mixes two sources" in line


def test_sweep_runs_a_chooser_with_its_floors(capsys, one_second_world, tmp_path):
    out = tmp_path / "sweep"
    code, _, err = run(
        capsys, "sweep", "--methods", f"{HERE}:HeldRandom", "--axes", "", "--profiles", "none",
        "--layouts", 0, "--worlds", one_second_world, "--workers", 1, "--out", out,
    )  # fmt: skip
    assert code == 0, err
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert {r["method"] for r in rows} == {f"{HERE}:HeldRandom", "random", "random@10"}
    meta = json.loads((out / "meta.json").read_text())
    assert meta["settings"]["method_sources"][f"{HERE}:HeldRandom"].startswith(f"{HERE}:HeldRandom")


def test_methods_says_which_learned_method_ships_a_policy(capsys, monkeypatch, tmp_path):
    (tmp_path / "d3dwa" / "seed-0").mkdir(parents=True)
    (tmp_path / "d3dwa" / "seed-0" / "meta.json").write_text("{}")
    (tmp_path / "d3dwa" / "seed-1").mkdir()
    (tmp_path / "d3dwa" / "seed-1" / "meta.json").write_text("{}")
    monkeypatch.setattr("d3dwa_bullet.cli.methods.default_policy_path", lambda m: tmp_path / m)
    code, out, _ = run(capsys, "methods", "--json")
    rows = {r["name"]: r for r in json.loads(out)}
    assert code == 0 and rows["d3dwa"]["policy"] == "shipped policy, 2 training seeds"
    assert rows["d3dwa-barn"]["policy"].startswith("no shipped policy")
    assert "policy" not in rows["dwa3"]  # a fixed method needs none
    code, out, _ = run(capsys, "methods")
    assert "D3DWA (BARN-trained)  [built-in; no shipped policy: train one" in out


def test_extending_a_directory_names_the_method_list_as_the_cause(
    capsys, one_second_world, tmp_path
):
    out = tmp_path / "res"
    base = ("eval", "--worlds", one_second_world, "--workers", 1, "--out", out)
    code, _, err = run(capsys, *base, "--methods", f"dwa3,{HERE}:Straight")
    assert code == 0, err
    line = refused(capsys, *base, "--methods", "dwa3,dwa1")
    assert "holds a method from outside the package" in line and "were written by" not in line
    assert f"list the methods already there (dwa3, {HERE}:Straight)" in line
    plain = tmp_path / "plain"
    assert run(capsys, *base[:-1], plain, "--methods", "dwa3")[0] == 0
    line = refused(capsys, *base[:-1], plain, "--methods", f"dwa3,{HERE}:Straight")
    assert "holds no method from outside the package" in line and "another --out" in line
