"""plan_answers: a plan run's cells where they stopped, with the rule's intervals, from its log."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plans.plan_file import load_plan
from d3dwa_bullet.evaluation.plans.run import ORDER_RECORD, run_plan
from d3dwa_bullet.evaluation.results import CSV_FIELDS
from d3dwa_bullet.loading import load_json
from tools.experiments.plan_answers import answers, cost, half_width, load_run, main

PLAN: dict[str, Any] = {
    "name": "answers test", "order_seed": 5, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03, "success": 0.05}, "profiles": ["none"],
    "families": {"R": {"strata": ["R1-style"], "looks": [20, 40], "maximum": 40}},
    "cells": [{"a": "good", "b": "base", "question": "policies"},
              {"a": "same", "b": "base", "question": "policies"}],
}  # fmt: skip
STRATA = {f"R1-style-s{i}": "R1-style" for i in range(40)}


def source(keys: Sequence[tuple[str, str, str]]) -> list[dict[str, Any]]:
    """'good' 0.2 above a layout's base score (and always arriving), 'same' within 0.002 of it."""
    rows = []
    for layout, profile, method in keys:
        i = sorted(STRATA).index(layout)
        noise = np.random.default_rng([i, ("base", "good", "same").index(method)]).normal(0, 0.002)
        score = 0.4 + 0.01 * (i % 7) + {"base": 0.0, "good": 0.2, "same": 0.0}[method] + noise
        outcome = "goal" if method == "good" or i % 3 else "timeout"
        rows.append({"world": layout, "noise": profile, "method": method, "seed": 0, "outcome": outcome,
                     "score": score})  # fmt: skip
    return rows


def _run(tmp_path: Path) -> tuple[Path, Path]:
    plan_path, out = tmp_path / "plan.yaml", tmp_path / "run"
    plan_path.write_text(yaml.safe_dump(PLAN))
    out.mkdir()
    run_plan(load_plan(plan_path), STRATA, source, out, "0.1.0")
    return plan_path, out


def test_each_cell_reads_with_the_interval_of_the_test_that_read_it(tmp_path: Path) -> None:
    plan_path, out = _run(tmp_path)
    plan, looks = load_run(out, plan_path)
    got = {r["a"]: r for r in answers(plan, looks)}
    good, same = got["good"], got["same"]
    assert good["decision"] == "A better" and good["low"] > 0 and good["look"] == 1
    assert same["decision"] == "equivalent" and -0.03 < same["low"] < same["high"] < 0.03
    # the rule's interval is wider than a plain 95 % one at the same look (it holds over the looks)
    last = [r for r in looks if r["a"] == "good"][-1]
    assert good["high"] - good["low"] > 2 * half_width(last["se"], last["df"], 1.959964)
    # success beside, on the layouts the look read: 'good' always arrives, 'base' where i % 3 != 0
    read = load_json(out / ORDER_RECORD, ConfigError)["R"][: good["layouts"]]
    fails = sum(sorted(STRATA).index(layout) % 3 == 0 for layout in read) / len(read)
    assert good["beside"]["success"]["difference"] == pytest.approx(fails)


def test_the_page_the_figure_and_a_plan_that_is_not_the_runs(tmp_path: Path, capsys: Any) -> None:
    plan_path, out = _run(tmp_path)
    assert main([str(out), "--plan", str(plan_path), "--figure", str(tmp_path / "a.png")]) == 0
    page = capsys.readouterr().out
    assert "## R" in page and "| `same` vs `base` | none | equivalent |" in page
    assert (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    other = tmp_path / "other.yaml"
    other.write_text(yaml.safe_dump({**PLAN, "order_seed": 6}))
    assert main([str(out), "--plan", str(other)]) == 2
    err = capsys.readouterr().err
    assert "not the plan" in err and len(err.strip().splitlines()) == 1


def test_the_cost_counts_the_episodes_held_against_the_fixed_design(tmp_path: Path) -> None:
    plan_path, out = _run(tmp_path)
    plan = load_plan(plan_path)
    read = load_json(out / ORDER_RECORD, ConfigError)["R"][:20]  # look 1 read every method here
    extra = {"time_s": 9.0, "tl_m": 2.0, "pd_rad": 0.1, "min_clearance_m": 0.3, "steps": 90, "score_barn": 0.2,
             "reference_length_m": 2.0, "policy_seed": ""}  # fmt: skip
    with open(out / "results.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        for r in source([(layout, "none", m) for layout in read for m in ("base", "good", "same")]):
            writer.writerow({**r, **extra})
    # three runs on each of the maximum's 40 layouts against the 60 episodes held
    assert cost(plan, out) == [{"family": "R", "episodes": 60, "fixed": 120, "ratio": 2.0}]
