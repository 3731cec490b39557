"""`d3dwa eval` over training seeds and `d3dwa compare`, through the command line."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import yaml

import d3dwa_bullet.evaluation.policy_runs as policy_runs
from d3dwa_bullet.cli.app import main
from tests.conftest import ONE_SECOND_WORLD
from tests.evaluation.test_policy_runs import seed_folder

NEAR_GOAL = dict(ONE_SECOND_WORLD, name="near", goal=[0.3, 0.0], time_limit=10.0)


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("seeds")
    world = root / "near.yaml"
    world.write_text(yaml.safe_dump(NEAR_GOAL))
    return world, seed_folder(root, seeds=(0, 1))


@pytest.fixture(scope="module")
def evaluated(setup, tmp_path_factory) -> Path:
    world, folder = setup
    out = tmp_path_factory.mktemp("res") / "res"
    argv = ["eval", "--worlds", str(world), "--methods", "d3dwa", "--policy", str(folder),
            "--seeds", "2", "--workers", "1", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    return out


def test_eval_runs_every_training_seed_and_names_it(evaluated):
    with (evaluated / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    # a greedy policy without noise repeats its episode: each training seed runs seed 0 only
    assert [(r["policy_seed"], r["seed"]) for r in rows] == [("0", "0"), ("1", "0")]
    table = (evaluated / "table.md").read_text()
    assert "| D3DWA | 2 training seeds, 2 episodes |" in table
    seeds = (evaluated / "table_seeds.md").read_text().splitlines()
    assert [line.split("|")[2].strip() for line in seeds if line.startswith("| D3DWA")] == [
        "0",
        "1",
    ]
    meta = json.loads((evaluated / "meta.json").read_text())
    assert meta["settings"]["policy_seeds"] == {"d3dwa": [0, 1]}
    assert (
        sorted(p.name for p in (evaluated / "logs").iterdir())[0] == "near__d3dwa__p0__none__s0.npz"
    )


def test_eval_refuses_a_seed_that_is_not_there(setup, tmp_path, capsys):
    world, folder = setup
    code = main(["eval", "--worlds", str(world), "--methods", "d3dwa", "--policy", str(folder),
                 "--policy-seeds", "0,4", "--out", str(tmp_path / "r")])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == (f"d3dwa: error: --policy-seeds: {folder} has no seed-4 (it has "
                                 "seed-0, seed-1)")  # fmt: skip
    assert not (tmp_path / "r").exists()


def test_compare_prints_the_probability_of_improvement(setup, tmp_path, capsys, monkeypatch):
    world, folder = setup
    # the seed folder stands in for the shipped policies/d3dwa/
    monkeypatch.setattr(policy_runs, "default_policy_path", lambda m, root=None: folder.parent / m)
    out = tmp_path / "both"
    twin = tmp_path / "twin.yaml"  # a second layout: compare's test is paired by layout
    twin.write_text(yaml.safe_dump(dict(NEAR_GOAL, name="twin")))
    assert main(["eval", "--worlds", f"{world},{twin}", "--methods", "dwa3,d3dwa", "--seeds",
                 "2", "--workers", "1", "--out", str(out)]) == 0  # fmt: skip
    with (out / "results.csv").open() as fh:
        outcomes = {r["outcome"] for r in csv.DictReader(fh)}
    assert outcomes == {"goal"}  # 0.3 m to go: every run of both reaches it
    capsys.readouterr()
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [g["group"] for g in report["groups"]] == ["custom, noise none", "all"]
    # every run ties with every run: P = 0.5 exactly, and so is its interval
    assert all((g["p"], g["low"], g["high"]) == (0.5, 0.5, 0.5) for g in report["groups"])
    # two training seeds against DWA III's one run: its noise-free episode ran once per layout
    assert report["groups"][-1]["runs_a"] == 2 and report["groups"][-1]["runs_b"] == 1
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3"]) == 0
    text = capsys.readouterr().out
    # 2 pairs (2 layouts, each side's one noise-free episode per training seed), all tied:
    # no evidence that A is higher, p = 1
    # (the table is split in two to fit the page's width, the tasks column in each)
    table = text.split("\n\nReadings")[0]
    cells = [c.strip() for ln in table.splitlines() if ln.startswith("| all |")
             for c in ln.split("|")[2:-1]]  # fmt: skip
    assert cells == ["2", "2", "1", "0.50", "[0.50, 0.50]", "2", "0 / 0", "1"]
    assert "P(D3DWA > DWA III" in text and report["groups"][-1]["paired_p"] == 1.0


def test_compare_names_a_method_that_is_not_in_the_results(evaluated, capsys):
    assert main(["compare", str(evaluated), "--methods", "d3dwa,dwa3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"d3dwa: error: {evaluated / 'results.csv'}: no rows of method 'dwa3' (it "
                   "has d3dwa)")  # fmt: skip


def test_compare_refuses_bad_methods(evaluated, capsys):
    assert main(["compare", str(evaluated), "--methods", "d3dwa"]) == 2  # A alone: its floors
    assert "no floor of method 'd3dwa' (random, random@10)" in capsys.readouterr().err
    assert main(["compare", str(evaluated), "--methods", "dwa1"]) == 2
    assert "--methods needs two different methods A,B" in capsys.readouterr().err
    assert main(["compare", str(evaluated), "--methods", "d3dwa,nope"]) == 2
    assert "unknown method 'nope'" in capsys.readouterr().err


def test_sweep_jobs_cover_every_training_seed(setup):
    from d3dwa_bullet.evaluation.sweep import SweepSettings, sweep_jobs

    _, folder = setup
    settings = SweepSettings(methods=("dwa3", "d3dwa"), worlds=("R1",), layouts=0, seeds=1,
                             axes=(), profiles=("none", "real"))  # fmt: skip
    jobs = sweep_jobs(settings, None)
    assert {(j.method, j.policy_seed) for j in jobs} >= {("dwa3", None)}
    one = SweepSettings(methods=("d3dwa",), worlds=("R1",), layouts=0, seeds=1, axes=(),
                        profiles=("none", "real"), policy_seeds="1")  # fmt: skip
    jobs = sweep_jobs(one, str(folder))
    assert [(j.policy_seed, j.noise) for j in jobs] == [(1, "none"), (1, "real")]
    assert jobs[0].policy == str(folder / "seed-1")
