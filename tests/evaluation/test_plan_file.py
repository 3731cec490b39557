"""The plan file: one format, its loader and checker, bad input in one line naming the value."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plans import check_plan, load_plan

GOOD: dict[str, Any] = {
    "name": "test plan",
    "order_seed": 7,
    "alpha": 0.05,
    "spending": "lan-demets-obrien-fleming",
    "headline": "score",
    "margins": {"score": 0.03, "success": 0.05},
    "profiles": ["none", "real"],
    "families": {
        "barn": {"strata": ["barn"], "looks": [100, 200], "maximum": 300},
        "r-style": {"strata": ["R1-style", "R2-style"], "looks": [50, 100], "maximum": 100},
    },
    "cells": [{"a": "d3dwa", "b": "dwa3", "question": "policies"},
              {"a": "d3dwa", "b": "d3dwa-weights", "question": "recipe"}],
}  # fmt: skip


def _with(path: str, value: Any) -> dict[str, Any]:
    data = copy.deepcopy(GOOD)
    *head, last = path.split(".")
    here = data
    for key in head:
        here = here[int(key)] if isinstance(here, list) else here[key]
    if value is KeyError:
        del here[last]
    else:
        here[last] = value
    return data


def test_a_good_plan_loads_with_its_last_look_at_the_maximum(tmp_path: Path) -> None:
    path = tmp_path / "plan.yaml"
    path.write_text(yaml.safe_dump(GOOD))
    plan = load_plan(path)
    barn, r_style = plan.families
    assert barn.looks == (100, 200, 300) and barn.fractions == (1 / 3, 2 / 3, 1.0)
    assert r_style.looks == (50, 100) and r_style.strata == ("R1-style", "R2-style")
    assert [c.question for c in plan.cells] == ["policies", "recipe"]
    assert plan.methods == ("d3dwa", "dwa3", "d3dwa-weights")
    assert plan.margins == {"score": 0.03, "success": 0.05}
    assert len(plan.digest) == 64
    path.write_text(yaml.safe_dump(GOOD) + "# a comment\n")
    assert load_plan(path).digest != plan.digest  # any change to the file changes its hash


@pytest.mark.parametrize(
    ("path", "value", "says"),
    [
        ("alpha", KeyError, "missing field 'alpha'"),
        ("colour", "blue", "unknown field 'colour'"),
        ("families.barn.looks", KeyError, "families.barn: missing field 'looks'"),
        ("families.barn.step", 3, "families.barn: unknown field 'step'"),
        ("cells.0.question", KeyError, "cells[0]: missing field 'question'"),
        (
            "cells.0.question",
            "seeds",
            "cells[0].question: must be one of policies, recipe, got 'seeds'",
        ),
        ("margins.score", 0, "margins.score: must be a positive finite number"),
        ("margins.score", -0.03, "got -0.03"),
        ("margins.score", float("nan"), "got nan"),
        ("margins.score", float("inf"), "got inf"),
        ("margins.score", "small", "got 'small'"),
        ("margins.speed", 0.1, "unknown metric 'speed'"),
        ("alpha", 0.5, "alpha must be a number in (0, 0.5), got 0.5"),
        ("alpha", 0, "got 0"),
        ("alpha", 1.2, "got 1.2"),
        ("families.barn.looks", [100, 100], "looks: must increase, got 100 after 100"),
        ("families.barn.looks", [200, 100], "looks: must increase, got 100 after 200"),
        (
            "families.barn.looks",
            [0, 100],
            "looks[0]: must be a whole number of layouts >= 1, got 0",
        ),
        (
            "families.barn.looks",
            [1, 100],
            "the first look needs 2 layouts or more (a paired test), got 1",
        ),
        ("families.barn.maximum", 50, "maximum: 50 is below the first look (100)"),
        ("families.barn.maximum", 150, "looks: 200 is beyond the maximum (150)"),
        ("spending", "pocock", "spending must be one of lan-demets-obrien-fleming, got 'pocock'"),
        ("headline", "speed", "headline must be one of"),
        ("order_seed", -1, "order_seed must be a whole number >= 0, got -1"),
        ("cells.0.b", "d3dwa", "a and b must differ"),
    ],
)
def test_bad_input_is_one_line_naming_the_value(path: str, value: Any, says: str) -> None:
    with pytest.raises(ConfigError) as err:
        check_plan(_with(path, value), "plan.yaml")
    assert says in str(err.value) and "\n" not in str(err.value)
    assert str(err.value).startswith("plan.yaml")


def test_the_headline_needs_a_margin() -> None:
    with pytest.raises(ConfigError, match="missing the headline metric 'score'"):
        check_plan(_with("margins", {"success": 0.05}), "plan.yaml")


def test_a_file_that_is_not_a_plan(tmp_path: Path) -> None:
    path = tmp_path / "plan.yaml"
    path.write_text("- just\n- a list\n")
    with pytest.raises(ConfigError, match="must be a mapping"):
        load_plan(path)
    with pytest.raises(ConfigError, match="missing.yaml"):
        load_plan(tmp_path / "missing.yaml")
