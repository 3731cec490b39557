"""Running a sequential plan over a source of episodes made here: looks, stops, the log, resuming."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plans import check_plan
from d3dwa_bullet.evaluation.plans.run import (
    LOOKS_LOG,
    LOOKS_PAGE,
    ORDER_RECORD,
    Key,
    code_identity,
    run_plan,
)
from d3dwa_bullet.loading import load_json, load_json_lines

PLAN: dict[str, Any] = {
    "name": "run test", "order_seed": 3, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none", "harsh"],
    "families": {"all": {"strata": ["barn", "R1-style"], "looks": [20, 40], "maximum": 60}},
    "cells": [{"a": "good", "b": "base", "question": "policies"},
              {"a": "close", "b": "base", "question": "policies"}],
}  # fmt: skip
STRATA = {f"BARN-{i}": "barn" for i in range(20)} | {
    f"R1-style-s{i}": "R1-style" for i in range(40)
}


class Source:
    """Episodes on demand: 'base' a layout's value, 'good' 0.3 above it, 'close' 0.005 above
    (noise 0.1 under harsh, 0.01 under none); remembers every key it ran."""

    def __init__(self) -> None:
        self.ran: set[Key] = set()

    def __call__(self, keys: Sequence[Key]) -> list[dict[str, Any]]:
        self.ran |= set(keys)
        rows = []
        for layout, profile, method in keys:
            rng = np.random.default_rng(
                [
                    sorted(STRATA).index(layout),
                    len(profile),
                    ("base", "good", "close").index(method),
                ]
            )
            base = 0.3 + 0.01 * sorted(STRATA).index(layout) % 0.4
            shift = {"base": 0.0, "good": 0.3, "close": 0.005}[method]
            score = base + shift + rng.normal(0, 0.1 if profile == "harsh" else 0.01)
            rows.append({"world": layout, "noise": profile, "method": method, "seed": 0,
                         "outcome": "timeout" if method == "base" else "goal", "score": score})  # fmt: skip
        return rows


def test_cells_stop_when_they_read_and_methods_when_no_open_cell_needs_them(tmp_path: Path) -> None:
    plan, source = check_plan(PLAN, "plan.yaml", "a" * 64), Source()
    records = run_plan(plan, STRATA, source, tmp_path, "0.1.0")
    final = {(r["a"], r["profile"]): r for r in records if r["decision"] != "open"}
    assert (
        final[("good", "none")]["decision"] == "A better" and final[("good", "none")]["look"] == 1
    )
    assert final[("close", "none")]["decision"] == "equivalent"
    assert final[("close", "harsh")]["look"] == 3  # the noisy near-tie runs to the maximum
    # se 0.023 at the maximum: neither a difference nor within +-0.03 can be shown
    assert final[("close", "harsh")]["decision"] == "inconclusive"
    ran = {(p, m): sum(1 for k in source.ran if k[1:] == (p, m)) for p in ("none", "harsh") for m in
           ("base", "good", "close")}  # fmt: skip
    assert (
        ran[("harsh", "good")] == 20
        and ran[("harsh", "base")] == 60
        and ran[("harsh", "close")] == 60
    )
    assert load_json_lines(tmp_path / LOOKS_LOG, ConfigError) == records
    assert "bound (difference)" in (tmp_path / LOOKS_PAGE).read_text()
    # the other metrics with a margin ride beside, on the same layouts: success 1 - 0 here
    plan2 = check_plan({**PLAN, "margins": {"score": 0.03, "success": 0.05}}, "plan.yaml", "b" * 64)
    (tmp_path / "two").mkdir()
    beside = run_plan(plan2, STRATA, Source(), tmp_path / "two", "0.1.0")[0]["beside"]
    assert records[0]["beside"] == {} and beside["success"]["difference"] == pytest.approx(1.0)
    # which layouts each look read: the family's order, its first `layouts`
    order = load_json(tmp_path / ORDER_RECORD, ConfigError)["all"]
    assert sorted(order) == sorted(STRATA) and order != sorted(STRATA)
    # resumed with the same plan and code: the same looks, the same log
    assert run_plan(plan, STRATA, Source(), tmp_path, "0.1.0") == records


def test_resuming_with_a_changed_plan_or_code_is_refused(tmp_path: Path) -> None:
    plan = check_plan(PLAN, "plan.yaml", "a" * 64)
    run_plan(plan, STRATA, Source(), tmp_path, "0.1.0")
    with pytest.raises(
        ConfigError,
        match=r"the plan file changed since this run began \(sha256 aaaaaaaaaaaa -> bbbb",
    ):
        run_plan(check_plan(PLAN, "plan.yaml", "b" * 64), STRATA, Source(), tmp_path, "0.1.0")
    with pytest.raises(
        ConfigError, match=r"the code changed since this run began \(0.1.0 -> 0.2.0\)"
    ):
        run_plan(plan, STRATA, Source(), tmp_path, "0.2.0")
    assert code_identity().startswith("0.1.0")


def test_a_family_whose_maximum_is_not_the_runs_layouts_is_refused(tmp_path: Path) -> None:
    plan = check_plan(PLAN, "plan.yaml", "a" * 64)
    with pytest.raises(ConfigError, match="maximum 60, but the run has 50 layouts"):
        run_plan(plan, dict(list(STRATA.items())[:50]), Source(), tmp_path, "0.1.0")
    assert not (tmp_path / "plan.json").exists()  # nothing recorded: a corrected plan may run here
