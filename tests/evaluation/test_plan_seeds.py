"""A plan's training seeds: each method's N lowest seed folders, found where the sweep finds them."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation import policy_runs
from d3dwa_bullet.evaluation.plans import check_plan
from d3dwa_bullet.evaluation.plans.plan_seeds import plan_seed_rows, plan_seed_spec, with_plan_seeds
from d3dwa_bullet.evaluation.policy_runs import method_runs, per_method_seeds
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings

PLAN: dict[str, Any] = {
    "name": "seeds", "order_seed": 1, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none"],
    "families": {"all": {"strata": ["R1-style"], "looks": [4], "maximum": 8}},
    "cells": [{"a": "d3dwa", "b": "d3dwa-weights", "question": "recipe"},
              {"a": "d3dwa", "b": "dwa3", "question": "recipe"}],
    "seeds": {"d3dwa": 3, "d3dwa-weights": 2},
}  # fmt: skip


@pytest.fixture
def root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Policy folders under tmp_path: d3dwa with seeds 0, 2, 5, 7 (gaps), d3dwa-weights with 1, 3."""
    for method, seeds in (("d3dwa", (7, 0, 5, 2)), ("d3dwa-weights", (3, 1))):
        for k in seeds:
            (tmp_path / method / f"seed-{k}").mkdir(parents=True)
    monkeypatch.setattr(
        policy_runs, "default_policy_path", lambda method, root=None: tmp_path / method
    )
    return tmp_path


def test_a_plan_takes_each_methods_lowest_numbered_seeds(root: Path) -> None:
    plan = check_plan(PLAN, "plan.yaml")
    assert plan.seeds == {"d3dwa": 3, "d3dwa-weights": 2}
    assert plan_seed_spec(plan) == "d3dwa=0,2,5;d3dwa-weights=1,3"
    settings = with_plan_seeds(SweepSettings(("d3dwa", "d3dwa-weights", "dwa3")), plan)
    assert settings.policy_seeds == "d3dwa=0,2,5;d3dwa-weights=1,3"
    assert with_plan_seeds(settings, plan) == settings  # a second pass keeps them
    # the sweep's runs are those seeds: _experiment finds no config.json, so any folder passes
    runs = method_runs(settings.methods, None, settings.policy_seeds)
    assert [(r.method, r.policy_seed) for r in runs] == [
        ("d3dwa", 0),
        ("d3dwa", 2),
        ("d3dwa", 5),
        ("d3dwa-weights", 1),
        ("d3dwa-weights", 3),
        ("dwa3", None),
    ]
    assert (
        plan_seed_spec(check_plan({k: v for k, v in PLAN.items() if k != "seeds"}, "p.yaml"))
        is None
    )


def test_a_folder_holding_fewer_seeds_than_the_plan_needs_is_refused(root: Path) -> None:
    data = copy.deepcopy(PLAN)
    data["seeds"]["d3dwa"] = 15
    with pytest.raises(ConfigError) as err:
        plan_seed_spec(check_plan(data, "plan.yaml"))
    assert (
        str(err.value)
        == f"plan plan.yaml: d3dwa has 4 training seeds ({root / 'd3dwa'}), the plan needs 15"
    )
    with pytest.raises(ConfigError, match="leave --policy-seeds out"):
        with_plan_seeds(
            SweepSettings(("d3dwa", "d3dwa-weights", "dwa3"), policy_seeds="0"),
            check_plan(PLAN, "p"),
        )


@pytest.mark.parametrize(
    ("seeds", "says"),
    [
        (
            {"d3dwa": 0, "d3dwa-weights": 2},
            "seeds.d3dwa: must be a whole number of training seeds >= 1, got 0",
        ),
        ({"d3dwa": 2.5, "d3dwa-weights": 2}, "got 2.5"),
        ({"d3dwa": True, "d3dwa-weights": 2}, "got True"),
        (
            {"d3dwa": 3, "d3dwa-weights": 2, "dwa3": 1},
            "seeds.dwa3: dwa3 is a fixed method, with no training seed",
        ),
        (
            {"d3dwa": 3, "d3dwa-weights": 2, "random@10": 1},
            "random@10 is a reference method, with no training",
        ),
        ({"d3dwa": 3, "d3dwa-weights": 2, "d3dwa-dr": 4}, "seeds.d3dwa-dr: no cell reads d3dwa-dr"),
        (
            {"d3dwa": 3},
            "cells[0] reads d3dwa-weights at the recipe level, but seeds does not list it",
        ),
        (
            {"d3dwa": 3, "d3dwa-weights": 2, "nonesuch": 1},
            "seeds.nonesuch: unknown method 'nonesuch'",
        ),
        ([3, 2], "seeds must be a non-empty mapping method: training seeds, got [3, 2]"),
        ({}, "seeds must be a non-empty mapping"),
    ],
)
def test_bad_seeds_are_one_line_naming_the_value(seeds: Any, says: str) -> None:
    with pytest.raises(ConfigError) as err:
        check_plan(PLAN | {"seeds": seeds}, "plan.yaml")
    assert says in str(err.value) and "\n" not in str(err.value)
    assert str(err.value).startswith("plan.yaml")


def test_per_method_policy_seeds_are_parsed_and_checked(root: Path) -> None:
    assert per_method_seeds("all") is None and per_method_seeds("0-4") is None
    assert per_method_seeds("d3dwa=0-2; d3dwa-weights=1") == {"d3dwa": "0-2", "d3dwa-weights": "1"}
    runs = method_runs(("d3dwa", "d3dwa-weights"), None, "d3dwa=5,7")
    assert [(r.method, r.policy_seed) for r in runs] == [("d3dwa", 5), ("d3dwa", 7), ("d3dwa-weights", 1),
                                                         ("d3dwa-weights", 3)]  # fmt: skip
    for spec, says in [("d3dwa=0;d3dwa=2", "names d3dwa twice"), ("d3dwa=", "is not method=seeds"),
                       ("dwa3=0", "dwa3 is not a learned method of this run"),
                       ("d3dwa=1", "has no seed-1")]:  # fmt: skip
        with pytest.raises(ConfigError, match=says):
            method_runs(("d3dwa", "d3dwa-weights", "dwa3"), None, spec)


def test_a_replayed_plan_keeps_each_methods_lowest_seeds_in_the_rows() -> None:
    rows = [{"method": m, "policy_seed": k, "world": w} for w in ("a", "b")
            for m, k in [("d3dwa", 4), ("d3dwa", 1), ("d3dwa", 9), ("d3dwa-weights", 0), ("d3dwa-weights", 2),
                         ("d3dwa-weights", 3), ("dwa3", None)]]  # fmt: skip
    kept = plan_seed_rows(rows, check_plan(PLAN, "plan.yaml"))
    assert sorted({(r["method"], r["policy_seed"]) for r in kept}, key=str) == sorted(
        {
            ("d3dwa", 1),
            ("d3dwa", 4),
            ("d3dwa", 9),
            ("d3dwa-weights", 0),
            ("d3dwa-weights", 2),
            ("dwa3", None),
        },
        key=str,
    )
    assert len(kept) == 12
    with pytest.raises(
        ResultsError,
        match="plan plan.yaml: the rows hold 2 training seeds of d3dwa, the plan needs 3",
    ):
        plan_seed_rows([r for r in rows if r["policy_seed"] != 9], check_plan(PLAN, "plan.yaml"))
