"""``d3dwa sweep --plan``: a sweep under a sequential plan, its looks, resume and refusals."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.sweep import read_sweep

PLAN: dict[str, Any] = {
    "name": "cli test", "order_seed": 1, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none"],
    "families": {"generated": {"strata": ["R1-style"], "looks": [2], "maximum": 4}},
    "cells": [{"a": "dwa1", "b": "dwa3", "question": "policies"}],
}  # fmt: skip


def _args(out: Path, plan: Path) -> list[str]:
    """Four unseen R1-style layouts, episodes cut at 1 s: every one a timeout scoring 0."""
    return ["sweep", "--methods", "dwa1,dwa3", "--worlds", "", "--styles", "R1-style", "--layouts", "4",
            "--axes", "", "--profiles", "", "--seeds", "1", "--time-limit", "1", "--workers", "1",
            "--out", str(out), "--plan", str(plan)]  # fmt: skip


def test_a_plan_stops_its_cell_at_the_first_look_and_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN))
    out = tmp_path / "run"
    assert main(_args(out, plan)) == 0
    printed = capsys.readouterr().out
    assert "dwa1 vs dwa3 under none: equivalent at look 1 (2 layouts" in printed
    looks = [json.loads(line) for line in (out / "looks.jsonl").read_text().splitlines()]
    assert [(r["look"], r["layouts"], r["decision"]) for r in looks] == [(1, 2, "equivalent")]
    assert len(read_sweep(out)) == 4  # 2 layouts x 2 methods: the other two layouts never ran
    assert main(_args(out, plan)) == 0  # resumed: nothing new to run, the same looks
    capsys.readouterr()
    assert len(read_sweep(out)) == 4
    plan.write_text(yaml.safe_dump(PLAN | {"order_seed": 2}))
    assert main(_args(out, plan)) == 2
    err = capsys.readouterr().err
    assert "the plan file changed since this run began" in err and err.count("\n") == 1


def test_a_plan_reads_a_directory_holding_more_than_its_looks_need(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run killed in a later look, or a whole sweep run before: resumed, nothing run again."""
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN))
    out = tmp_path / "run"
    assert main(_args(out, plan)[:-2]) == 0  # the plain sweep: all 4 layouts x 2 methods
    assert len(read_sweep(out)) == 8
    assert main(_args(out, plan)) == 0
    assert "equivalent at look 1 (2 layouts" in capsys.readouterr().out
    assert len(read_sweep(out)) == 8


@pytest.mark.parametrize(
    ("change", "says"),
    [
        ({"alpha": 0.7}, "alpha must be a number in (0, 0.5), got 0.7"),
        (
            {"cells": [{"a": "dwa2", "b": "dwa3", "question": "policies"}]},
            "plan cell method 'dwa2' is not in --methods",
        ),
        ({"profiles": ["harsh"]}, "plan profile 'harsh' is not in --profiles"),
    ],
)
def test_a_bad_plan_is_one_line_before_any_episode(
    change: dict[str, Any], says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN | change))
    assert main(_args(tmp_path / "run", plan)) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
    assert not (tmp_path / "run" / "results.csv").exists()


def _dr_args(out: Path, plan: Path, *extra: str) -> list[str]:
    return ["sweep", "--methods", "d3dwa-dr,dwa3", "--worlds", "", "--styles", "R1-style", "--layouts", "4",
            "--axes", "", "--profiles", "", "--seeds", "1", "--time-limit", "1", "--workers", "1",
            "--out", str(out), "--plan", str(plan), *extra]  # fmt: skip


@pytest.mark.parametrize(
    ("seeds", "extra", "says"),
    [
        ({"d3dwa-dr": 15}, (), "d3dwa-dr has 5 training seeds ("),
        ({"d3dwa-dr": 15}, (), "policies/d3dwa-dr), the plan needs 15"),
        (
            {"d3dwa-dr": 2},
            ("--policy-seeds", "0,1"),
            "the plan {plan} names its training seeds (seeds:); leave",
        ),
    ],
)
def test_a_plan_needing_more_training_seeds_than_the_folder_holds_is_refused_before_any_episode(
    seeds: dict[str, int],
    extra: tuple[str, ...],
    says: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    plan = tmp_path / "plan.yaml"
    cells = [{"a": "d3dwa-dr", "b": "dwa3", "question": "recipe"}]
    plan.write_text(yaml.safe_dump(PLAN | {"cells": cells, "seeds": seeds}))
    assert main(_dr_args(tmp_path / "run", plan, *extra)) == 2
    err = capsys.readouterr().err
    says = says.format(plan=plan)
    assert f"plan {plan}: d3dwa-dr" in err or "--policy-seeds 0,1" in err
    assert says in err and err.count("\n") == 1
    assert not (tmp_path / "run" / "results.csv").exists()
