"""``d3dwa sweep --plan`` with cells across global-plan settings: one sweep directory a setting,
the sides' names in the looks, resume, and the options such a plan refuses."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.results import read_meta
from d3dwa_bullet.evaluation.sweep import read_sweep

PLAN: dict[str, Any] = {
    "name": "across cli test", "order_seed": 5, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none"],
    "families": {"BARN": {"strata": ["barn"], "looks": [2], "maximum": 3}},
    "cells": [{"a": "dwa3", "b": "dwa3", "question": "policies", "global_plan": ["scan", "none"]},
              {"a": "dwa1", "b": "dwa3", "question": "policies"}],
}  # fmt: skip


def _args(out: Path, plan: Path, *extra: str) -> list[str]:
    """Three BARN challenge worlds, episodes cut at 5 s: every one a timeout scoring 0."""
    return ["sweep", "--suite", "barn", "--split", "challenge", "--world-ids", "0,6,12", "--methods", "dwa1,dwa3",
            "--axes", "", "--profiles", "", "--seeds", "1", "--time-limit", "5", "--workers", "1",
            "--out", str(out), "--plan", str(plan), *extra]  # fmt: skip


def test_each_setting_runs_in_its_own_sweep_directory_and_the_looks_name_the_sides(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN, sort_keys=False))
    out = tmp_path / "run"
    assert main(_args(out, plan)) == 0
    printed = capsys.readouterr().out
    assert (
        "BARN: dwa3 [global-plan scan] vs dwa3 [global-plan none] under none: equivalent at look 1"
        in printed
    )
    assert "BARN: dwa1 vs dwa3 under none: equivalent at look 1" in printed
    assert f"episodes with --global-plan scan: {out / 'global-plan-scan'}" in printed
    looks = [json.loads(line) for line in (out / "looks.jsonl").read_text().splitlines()]
    assert [(r["a"], r["b"]) for r in looks] == [("dwa3 [global-plan scan]", "dwa3 [global-plan none]"),
                                                 ("dwa1", "dwa3")]  # fmt: skip
    assert (
        "`dwa3 [global-plan scan]` vs `dwa3 [global-plan none]`" in (out / "looks.md").read_text()
    )
    # the plan's files in --out, the episodes in a plain sweep directory a setting
    assert not (out / "results.csv").exists() and (out / "plan.json").exists()
    scan, none = read_sweep(out / "global-plan-scan"), read_sweep(out / "global-plan-none")
    assert [r["method"] for r in scan] == ["dwa3", "dwa3"] and {r["global_plan"] for r in scan} == {
        "scan"
    }
    # dwa1 under the sweep's own (none) beside dwa3's episodes without the plan, run once for both cells
    assert sorted(r["method"] for r in none) == ["dwa1", "dwa1", "dwa3", "dwa3"]
    assert all("global_plan" not in r for r in none)
    assert {r["world"] for r in none} == {r["world"] for r in scan}  # the same first two layouts
    assert "global_plan" in (out / "global-plan-scan" / "results.csv").read_text().splitlines()[0]
    assert read_meta(out / "global-plan-scan")["settings"]["global_plan"] == "scan"
    assert "global_plan" not in read_meta(out / "global-plan-none")["settings"]
    # resumed: nothing runs again, the same looks
    assert main(_args(out, plan)) == 0
    capsys.readouterr()
    assert (
        len(read_sweep(out / "global-plan-scan")) == 2
        and len(read_sweep(out / "global-plan-none")) == 4
    )
    assert [json.loads(line) for line in (out / "looks.jsonl").read_text().splitlines()] == looks


@pytest.mark.parametrize(
    ("change", "extra", "says"),
    [
        ({}, ("--reuse", "{other}"), "--reuse: the plan {plan} runs one directory per global-plan setting"),
        ({"cells": PLAN["cells"][:1]}, ("--global-plan", "scan"),
         "--global-plan scan: every cell of the plan {plan} names its sides' global plans"),
        ({"cells": [PLAN["cells"][0] | {"global_plan": ["scan", "bogus"]}]}, (),
         "cells[0].global_plan[1]: must be a --global-plan value (none, scan, map), got 'bogus'"),
    ],
)  # fmt: skip
def test_a_plan_across_settings_refuses_what_it_cannot_honour_in_one_line(
    change: dict[str, Any], extra: tuple[str, ...], says: str, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN | change))
    other = tmp_path / "other"
    other.mkdir()
    (other / "results.csv").write_text("world\n")
    (other / "meta.json").write_text("{}")
    args = [a.format(other=other) for a in extra]
    assert main(_args(tmp_path / "run", plan, *args)) == 2
    err = capsys.readouterr().err
    assert says.format(plan=plan) in err and err.count("\n") == 1
    assert not (tmp_path / "run" / "global-plan-scan").exists()
