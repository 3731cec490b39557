"""Plan cells across a global-plan setting: the field, its sides' names, their directories, the
relabelling source, and a plan run through it on episodes made here (no simulator)."""

from __future__ import annotations

import copy
import hashlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plans import check_plan, load_plan
from d3dwa_bullet.evaluation.plans.plan_file import Cell, side_label
from d3dwa_bullet.evaluation.plans.run import LOOKS_PAGE, Key, run_plan
from d3dwa_bullet.evaluation.plans.setting_sides import (
    Side,
    check_setting_options,
    plan_sides,
    setting_dirs,
    side_source,
)

REPO = Path(__file__).resolve().parents[2]
ACROSS: dict[str, Any] = {
    "name": "across", "order_seed": 4, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03, "success": 0.05}, "profiles": ["none", "harsh"],
    "families": {"BARN": {"strata": ["barn"], "looks": [10, 20], "maximum": 30}},
    "cells": [{"a": "dwa3", "b": "dwa3", "question": "policies", "global_plan": ["scan", "none"]},
              {"a": "d3dwa", "b": "d3dwa", "question": "recipe", "global_plan": ["scan", "none"]}],
    "seeds": {"d3dwa": 5},
    "multiplicity": "holm",
}  # fmt: skip


def _with_cell(**fields: Any) -> dict[str, Any]:
    data = copy.deepcopy(ACROSS)
    data["cells"].append({"a": "dwa1", "b": "dwa1", "question": "policies"} | fields)
    return data


def test_a_cell_across_a_setting_may_read_a_method_against_itself() -> None:
    plan = check_plan(ACROSS, "plan.yaml")
    assert plan.cells[0] == Cell("dwa3", "dwa3", "policies", ("scan", "none"))
    assert plan.cells[0].sides == ("dwa3 [global-plan scan]", "dwa3 [global-plan none]")
    assert plan.cells[1].sides == (side_label("d3dwa", "scan"), side_label("d3dwa", "none"))
    assert plan.methods == ("dwa3", "d3dwa")  # what check_fits and seeds read: the methods
    assert plan.global_plans == ("scan", "none")
    assert plan.seeds == {"d3dwa": 5}
    # map: a sweep's episodes always have their world's map, so it is accepted
    mapped = check_plan(_with_cell(global_plan=["map", "scan"]), "plan.yaml")
    assert mapped.cells[2].sides == ("dwa1 [global-plan map]", "dwa1 [global-plan scan]")
    assert mapped.global_plans == ("scan", "none", "map")


@pytest.mark.parametrize(
    ("value", "says"),
    [
        (["scan"], "cells[2].global_plan: must be a list of two --global-plan values [A's, B's], got ['scan']"),
        ("scan", "cells[2].global_plan: must be a list of two --global-plan values [A's, B's], got 'scan'"),
        (["scan", "none", "map"], "got ['scan', 'none', 'map']"),
        (["scan", "bogus"], "cells[2].global_plan[1]: must be a --global-plan value (none, scan, map), got 'bogus'"),
        ([None, "scan"], "cells[2].global_plan[0]: must be a --global-plan value (none, scan, map), got None"),
        (["scan", "scan"], "cells[2].global_plan: the two sides must differ, got 'scan' twice"),
    ],
)  # fmt: skip
def test_a_bad_global_plan_is_one_line_naming_file_field_and_value(value: Any, says: str) -> None:
    with pytest.raises(ConfigError) as err:
        check_plan(_with_cell(global_plan=value), "plan.yaml")
    text = str(err.value)
    assert text.startswith("plan.yaml: ") and says in text and "\n" not in text


def test_without_the_field_a_method_against_itself_is_still_refused_and_a_pair_twice_too() -> None:
    with pytest.raises(ConfigError, match=r"cells\[2\]: a and b must differ, got 'dwa1' twice"):
        check_plan(_with_cell(), "plan.yaml")
    twice = copy.deepcopy(ACROSS)
    twice["cells"].append(dict(twice["cells"][0]))
    with pytest.raises(ConfigError, match="cells: a pair is given twice"):
        check_plan(twice, "plan.yaml")
    # the same methods across other settings are another pair
    other = _with_cell(global_plan=["map", "none"]) | {}
    other["cells"][2] |= {"a": "dwa3", "b": "dwa3"}
    assert len(check_plan(other, "plan.yaml").cells) == 3


@pytest.mark.parametrize(
    "path", ["docs/pilots/recipes/plan.yaml", "docs/pilots/yardstick-barn/sequential-retro.yaml"]
)
def test_a_committed_plan_without_the_field_reads_as_before(path: str) -> None:
    plan = load_plan(REPO / path)
    assert plan.digest == hashlib.sha256((REPO / path).read_bytes()).hexdigest()
    assert plan.global_plans == () and all(c.global_plan is None for c in plan.cells)
    assert [c.sides for c in plan.cells] == [(c.a, c.b) for c in plan.cells]
    assert (
        setting_dirs(plan, "none") == {} and setting_dirs(plan, "scan") == {}
    )  # the sweep runs in --out


def test_each_side_runs_under_its_setting_in_its_own_directory() -> None:
    mixed = copy.deepcopy(ACROSS)
    mixed["cells"].append(
        {"a": "d3dwa", "b": "dwa3", "question": "policies"}
    )  # under the sweep's own
    plan = check_plan(mixed, "plan.yaml")
    sides = plan_sides(plan, "map")
    assert sides["dwa3 [global-plan scan]"] == Side("scan", "dwa3")
    assert sides["d3dwa [global-plan none]"] == Side("none", "d3dwa")
    assert sides["d3dwa"] == Side("map", "d3dwa") and sides["dwa3"] == Side("map", "dwa3")
    assert setting_dirs(plan, "map") == {"scan": "global-plan-scan", "none": "global-plan-none",
                                         "map": "global-plan-map"}  # fmt: skip
    assert setting_dirs(plan, "none") == {"scan": "global-plan-scan", "none": "global-plan-none"}


def test_options_a_plan_across_settings_cannot_honour_are_refused() -> None:
    plan = check_plan(ACROSS, "plans/gp.yaml")
    with pytest.raises(
        ConfigError, match=r"^--global-plan scan: every cell of the plan plans/gp.yaml names"
    ):
        check_setting_options(plan, "scan", reuse=False)
    with pytest.raises(
        ConfigError, match=r"^--reuse: the plan plans/gp.yaml runs one directory per"
    ):
        check_setting_options(plan, "none", reuse=True)
    check_setting_options(plan, "none", reuse=False)  # accepted
    # a cell without the field runs under --global-plan, so it is not refused then
    mixed = copy.deepcopy(ACROSS)
    mixed["cells"].append({"a": "d3dwa", "b": "dwa3", "question": "policies"})
    check_setting_options(check_plan(mixed, "plans/gp.yaml"), "scan", reuse=False)
    # a plan as before: both options as before
    before = copy.deepcopy(ACROSS)
    before["cells"] = [{"a": "d3dwa", "b": "dwa3", "question": "policies"}]
    before.pop("seeds")
    check_setting_options(check_plan(before, "plans/gp.yaml"), "scan", reuse=True)


class SettingEpisodes:
    """Episodes on demand per setting: every method's score on a layout is its base there plus
    0.2 under ``scan`` (noise 0.05); remembers each call's setting and keys."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, list[Key]]] = []

    def __call__(self, setting: str, keys: Sequence[Key]) -> list[dict[str, Any]]:
        self.calls.append((setting, list(keys)))
        rows = []
        for layout, profile, method in keys:
            i = int(layout.split("-")[1])
            rng = np.random.default_rng([i, len(profile), len(method), len(setting)])
            score = 0.4 + 0.01 * (i % 7) + (0.2 if setting == "scan" else 0.0) + rng.normal(0, 0.05)
            rows.append({"world": layout, "noise": profile, "method": method, "seed": 0, "outcome": "goal",
                         "score": score, "global_plan": setting})  # fmt: skip
        return rows


def test_the_source_relabels_each_rows_method_to_the_side_it_was_asked_for() -> None:
    run = SettingEpisodes()
    sides = {"dwa3 [global-plan scan]": Side("scan", "dwa3"), "dwa3 [global-plan none]": Side("none", "dwa3"),
             "dwa3": Side("none", "dwa3")}  # fmt: skip
    source = side_source(sides, run)
    rows = source([("BARN-0", "none", "dwa3 [global-plan scan]"), ("BARN-0", "none", "dwa3 [global-plan none]"),
                   ("BARN-6", "none", "dwa3"), ("BARN-0", "none", "dwa3")])  # fmt: skip
    # one call a setting, with the methods' keys; a key two sides share is asked once
    assert sorted(run.calls) == [("none", [("BARN-0", "none", "dwa3"), ("BARN-6", "none", "dwa3")]),
                                 ("scan", [("BARN-0", "none", "dwa3")])]  # fmt: skip
    got = sorted((r["world"], r["method"], r["global_plan"]) for r in rows)
    assert got == [("BARN-0", "dwa3", "none"), ("BARN-0", "dwa3 [global-plan none]", "none"),
                   ("BARN-0", "dwa3 [global-plan scan]", "scan"), ("BARN-6", "dwa3", "none")]  # fmt: skip
    scan = next(r for r in rows if r["method"] == "dwa3 [global-plan scan]")
    plain = next(r for r in rows if r["method"] == "dwa3 [global-plan none]")
    assert scan["score"] - plain["score"] > 0.05  # each side's own episodes, not one copied


def test_a_plan_across_settings_reads_a_method_against_itself(tmp_path: Path) -> None:
    data = copy.deepcopy(ACROSS)
    data["cells"] = [data["cells"][0]]
    data.pop("seeds")
    plan = check_plan(data, "plan.yaml", "c" * 64)
    strata = {f"BARN-{6 * i}": "barn" for i in range(30)}
    run = SettingEpisodes()
    records = run_plan(plan, strata, side_source(plan_sides(plan, "none"), run), tmp_path, "0.1.0")
    last = {r["profile"]: r for r in records}
    assert {r["a"] for r in records} == {"dwa3 [global-plan scan]"}
    assert {r["b"] for r in records} == {"dwa3 [global-plan none]"}
    # +0.2 with the plan, se about 0.07 / sqrt(10): read at the first look under both profiles
    assert last["none"]["decision"] == last["harsh"]["decision"] == "A better"
    assert last["none"]["look"] == 1 and 0.15 < last["none"]["difference"] < 0.25
    assert {s for s, _ in run.calls} == {"scan", "none"}
    assert (
        "`dwa3 [global-plan scan]` vs `dwa3 [global-plan none]`"
        in (tmp_path / LOOKS_PAGE).read_text()
    )


def test_issue_80s_committed_plan_reads_each_method_against_itself_across_the_plan() -> None:
    path = REPO / "docs/pilots/global-plan-sequential/plan.yaml"
    plan = load_plan(path)
    assert [c.sides for c in plan.cells] == [("dwa3 [global-plan scan]", "dwa3 [global-plan none]"),
                                             ("d3dwa [global-plan scan]", "d3dwa [global-plan none]")]  # fmt: skip
    assert [c.question for c in plan.cells] == ["policies", "recipe"] and plan.seeds == {"d3dwa": 5}
    assert (
        plan.cell_count == 6
        and plan.multiplicity == "holm"
        and plan.families[0].looks == (20, 35, 50)
    )
    assert setting_dirs(plan, "none") == {"scan": "global-plan-scan", "none": "global-plan-none"}
    with pytest.raises(ConfigError, match="--global-plan scan: every cell"):
        check_setting_options(plan, "scan", reuse=False)
