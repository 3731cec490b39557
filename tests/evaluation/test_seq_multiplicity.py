"""A plan's multiplicity control: levels, recycling within a look, the run's log, and the familywise
false-read rate by simulation (docs/design/sequential-plans.md#multiplicity)."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plans import check_plan, load_plan
from d3dwa_bullet.evaluation.plans.looks import A_BETTER, EQUIVALENT
from d3dwa_bullet.evaluation.plans.recycling import LevelBounds, Levels, read_look
from d3dwa_bullet.evaluation.plans.run import LOOKS_PAGE, Key, run_plan
from d3dwa_bullet.evaluation.plans.simulate import false_and_true, simulate_cells

PATHS = 200_000
"""Null paths of each level's bounds here (the plan's 2,000,000 take seconds a level)."""
PLAN: dict[str, Any] = {
    "name": "holm test", "order_seed": 3, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none", "harsh"],
    "families": {"all": {"strata": ["R1-style"], "looks": [10, 20], "maximum": 20}},
    "cells": [{"a": "mid", "b": "base", "question": "policies"},
              {"a": "close", "b": "base", "question": "policies"}],
    "multiplicity": "holm",
}  # fmt: skip


def test_levels_of_each_rule() -> None:
    assert Levels("none", 0.05, 4).level(np.array([0, 3])).tolist() == [0.05, 0.05]
    assert Levels("bonferroni", 0.05, 4).level(np.array([0, 3])).tolist() == [0.0125, 0.0125]
    assert np.allclose(
        Levels("holm", 0.05, 4).level(np.array([0, 1, 3, 9])), [0.0125, 0.05 / 3, 0.05, 0.05]
    )
    with pytest.raises(ValueError, match="levels need a rule"):
        Levels("hochberg", 0.05, 4)


def test_a_plan_names_its_multiplicity_or_reads_as_before(tmp_path: Path) -> None:
    plan = check_plan(PLAN, "plan.yaml")
    assert plan.multiplicity == "holm" and plan.cell_count == 4  # 2 pairs x 2 profiles x 1 family
    retro = load_plan("docs/pilots/yardstick-barn/sequential-retro.yaml")
    assert retro.multiplicity == "none" and retro.seeds == {} and retro.cell_count == 24
    with pytest.raises(ConfigError) as err:
        check_plan(PLAN | {"multiplicity": "hochberg"}, "plan.yaml")
    assert (
        str(err.value)
        == "plan.yaml: multiplicity must be one of none, bonferroni, holm, got 'hochberg'"
    )


def test_a_raised_levels_bounds_are_lower_at_every_look_and_a_difference_implies_tosts_side() -> (
    None
):
    """The two facts the familywise argument rests on (the module's docstring of recycling)."""
    bounds = LevelBounds((10, 20, 30, 40, 50), 50, PATHS)
    table = [bounds.at(0.05 / j) for j in (6, 5, 4, 3, 2, 1)]
    for (low_d, low_t), (high_d, high_t) in pairwise(table):
        assert np.all(high_d < low_d) and np.all(high_t < low_t)
    for bd, bt in table:
        assert np.all(bd > bt)  # a difference read crosses the matching side of TOST as well


def test_a_cell_reading_a_difference_and_equivalence_passes_its_level_within_the_look() -> None:
    """Three cells, large df: the first reads at alpha / 3; each read passes, so the next reads at
    the raised level within the same look. Bonferroni shows the first difference only."""
    bounds = LevelBounds((10, 20), 20, PATHS)
    b = {j: bounds.at(0.05 / j)[0][1] for j in (1, 2, 3)}
    se = np.full((1, 3), 0.001)
    d = se * np.array([[b[3] + 1, (b[3] + b[2]) / 2, (b[2] + b[1]) / 2]])
    df, is_open = np.full((1, 3), 1e6), np.ones((1, 3), dtype=bool)
    code, passed, level = read_look(
        d, se, df, 0.03, is_open, np.zeros(1, int), Levels("holm", 0.05, 3), bounds, 1
    )
    assert code.tolist() == [[A_BETTER] * 3] and passed.tolist() == [3]
    assert np.allclose(level, [[0.05 / 3, 0.05 / 2, 0.05]])  # each read at the level it came at
    code, passed, level = read_look(d, se, df, 0.03, is_open, np.zeros(1, int), Levels("bonferroni", 0.05, 3),
                                    bounds, 1)  # fmt: skip
    assert code.tolist() == [[A_BETTER, EQUIVALENT, EQUIVALENT]] and passed.tolist() == [
        0
    ]  # no difference shown
    assert np.allclose(level, 0.05 / 3)
    # read only as a difference (outside the margin): the cell keeps its level, nothing passes
    code, passed, _ = read_look(
        d + 0.05, se, df, 0.03, is_open, np.zeros(1, int), Levels("holm", 0.05, 3), bounds, 1
    )
    assert code.tolist() == [[A_BETTER] * 3] and passed.tolist() == [0]


class Source:
    """'mid' 0.015 above 'base' with noise 0.001 (reads a difference and equivalence at once),
    'close' 0.005 above with noise 0.01 under none, 0.1 under harsh."""

    def __call__(self, keys: Sequence[Key]) -> list[dict[str, Any]]:
        rows = []
        for layout, profile, method in keys:
            i = int(layout.rsplit("s", 1)[1])
            rng = np.random.default_rng([i, len(profile), ("base", "mid", "close").index(method)])
            noise = {"mid": 0.001, "close": 0.1 if profile == "harsh" else 0.01, "base": 0.0}[
                method
            ]
            shift = {"base": 0.0, "mid": 0.015, "close": 0.005}[method]
            rows.append({"world": layout, "noise": profile, "method": method, "seed": 0, "outcome": "goal",
                         "score": 0.3 + 0.01 * i + shift + rng.normal(0, noise)})  # fmt: skip
        return rows


def test_a_holm_run_records_each_cells_level_at_each_look(tmp_path: Path) -> None:
    strata = {f"R1-style-s{i}": "R1-style" for i in range(20)}
    records = run_plan(check_plan(PLAN, "plan.yaml", "a" * 64), strata, Source(), tmp_path, "0.1.0")
    first = [r for r in records if r["look"] == 1]
    # both 'mid' cells read at 0.05 / 4 and pass at look 1: the 'close' cells are re-read at 0.05 / 2
    assert {(r["a"], r["profile"]): r["decision"] for r in first}[("mid", "none")] == "A better"
    assert {r["level"] for r in first if r["a"] == "mid"} == {0.0125}
    assert {r["level"] for r in first if r["decision"] == "open"} == {0.025}
    assert {r["level"] for r in records if r["look"] == 2} == {0.025}
    assert "| level |" in (tmp_path / LOOKS_PAGE).read_text().replace("level  ", "level ")
    assert "multiplicity holm over 4 cells" in (tmp_path / LOOKS_PAGE).read_text()
    (tmp_path / "n").mkdir()
    none = run_plan(
        check_plan(PLAN | {"multiplicity": "none"}, "p", "b" * 64),
        strata,
        Source(),
        tmp_path / "n",
        "0",
    )
    assert {r["level"] for r in none} == {0.05}


def test_the_familywise_false_read_rate_is_at_most_alpha_and_holm_reads_at_least_as_much() -> None:
    """Six cells of 100 layouts, five looks: two ties, one on each margin, two inside it (read a
    difference and equivalence at once, so they pass their level under Holm). 6,000 replicates a
    rule: three Monte Carlo standard errors allowed over alpha."""
    true, sd, margin = np.array([0.0, 0.0, 0.3, -0.3, 0.15, -0.15]), [1, 1, 1, 1, 0.3, 0.3], 0.3
    got = {}
    for rule in ("bonferroni", "holm", "none"):
        code = simulate_cells(true, sd, 100, margin, 5, 6000, 11, Levels(rule, 0.05, 6), PATHS)
        got[rule] = false_and_true(code, true, margin)
    limit = 0.05 + 3 * np.sqrt(0.05 * 0.95 / 6000)
    assert got["bonferroni"][0].mean() <= limit and got["holm"][0].mean() <= limit
    assert got["none"][0].mean() > 0.1  # six cells each at 5 %: the control is needed
    assert np.all(got["holm"][1] >= got["bonferroni"][1])  # the same draws: holm never reads less
    assert got["holm"][1].mean() > got["bonferroni"][1].mean()
