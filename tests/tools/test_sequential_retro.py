"""The sequential retro-check on rows made here: early stops, episodes saved, agreement."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.plans import check_plan
from d3dwa_bullet.evaluation.plans.order import stratum_of
from tools.experiments.sequential_retro import main, page, replay

PLAN: dict[str, Any] = {
    "name": "test", "order_seed": 5, "alpha": 0.05, "spending": "lan-demets-obrien-fleming",
    "headline": "score", "margins": {"score": 0.03}, "profiles": ["none"],
    "families": {"pooled": {"strata": ["barn", "R1-style"], "looks": [20, 40], "maximum": 80}},
    "cells": [{"a": "good", "b": "base", "question": "policies"},
              {"a": "same", "b": "base", "question": "policies"}],
}  # fmt: skip


def _rows(layouts: int = 40) -> list[dict[str, Any]]:
    """A results table: per BARN world and R1-style layout, 'base' once, 'good' (0.3 higher)
    and 'same' (as base, noise 0.005) at two training seeds each."""
    rng = np.random.default_rng(0)
    rows = []
    for i in range(2 * layouts):
        world, layout = (
            (f"BARN-{i}", "barn-easy") if i < layouts else (f"R1-style-s{i}", "generated")
        )
        base = rng.uniform(0.2, 0.6)
        runs = [("base", None, base)] + [
            ("good", s, base + 0.3 + rng.normal(0, 0.05)) for s in (0, 1)
        ]
        runs += [("same", s, base + rng.normal(0, 0.005)) for s in (0, 1)]
        for method, seed, score in runs:
            rows.append({"world": world, "layout": layout, "method": method, "policy_seed": seed,
                         "seed": 0, "noise": "none", "outcome": "goal", "score": score})  # fmt: skip
    return rows


def test_clear_cells_stop_early_and_agree_with_the_fixed_reading() -> None:
    plan = check_plan(PLAN, "plan.yaml", "0" * 64)
    result = replay(_rows(), plan, orders=5)
    good, same = result["cells"]
    assert good["fixed"]["reading"] == "A better" and same["fixed"]["reading"] == "equivalent"
    assert (good["layouts"] == 20).all() and (
        same["layouts"] == 20
    ).all()  # both read at the first look
    assert result["fixed_episodes"] == 80 * 5
    assert result["episodes"].tolist() == [20 * 5] * 6  # every method stops after the first look
    text = page(result, plan, "the command")
    assert "4.00x fewer" in text and "Committed order: 2 of 2 cells" in text


def test_a_method_runs_while_an_open_cell_needs_it() -> None:
    data = PLAN | {"margins": {"score": 0.0001}}  # 'same' can neither differ nor be equivalent
    result = replay(_rows(), check_plan(data, "plan.yaml", "0" * 64), orders=0)
    good, same = result["cells"]
    assert good["layouts"][0] == 20 and same["layouts"][0] == 80
    # base and same run all 80 layouts (1 + 2 rows), good only the first look's 20 (2 rows)
    assert result["episodes"][0] == 80 * 3 + 20 * 2


def test_refusals() -> None:
    rows = _rows()
    assert stratum_of(rows[0]) == "barn" and stratum_of(rows[-1]) == "R1-style"
    wrong = PLAN | {
        "families": {"pooled": {"strata": ["barn", "R1-style"], "looks": [20], "maximum": 70}}
    }
    with pytest.raises(ResultsError, match="maximum 70, but the rows hold 80 layouts"):
        replay(rows, check_plan(wrong, "plan.yaml"), orders=0)
    recipe = PLAN | {"cells": [{"a": "good", "b": "base", "question": "recipe"}]}
    with pytest.raises(ConfigError, match="question 'recipe' does not replay here"):
        replay(rows, check_plan(recipe, "plan.yaml"), orders=0)
    with pytest.raises(
        ConfigError, match="multiplicity holm: the retro-check replays each cell at alpha"
    ):
        replay(rows, check_plan(PLAN | {"multiplicity": "holm"}, "plan.yaml"), orders=0)
    # one directory holds one --global-plan setting: both sides would be its episodes, read as a tie
    across = PLAN | {
        "cells": [
            {"a": "good", "b": "good", "question": "policies", "global_plan": ["scan", "none"]}
        ]
    }
    with pytest.raises(
        ConfigError, match=r"cell good,good: global_plan \['scan', 'none'\] reads across settings"
    ):
        replay(rows, check_plan(across, "plan.yaml"), orders=0)


def test_bad_input_is_one_line_and_exit_two(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "plan.yaml"
    bad.write_text(yaml.safe_dump(PLAN | {"alpha": 0.7}))
    for argv, says in (
        ([str(tmp_path), "--plan", str(bad)], "alpha must be a number in (0, 0.5), got 0.7"),
        (
            [str(tmp_path), "--plan", str(bad), "--orders", "-1"],
            "--orders must be between 0 and 10000, got -1",
        ),
    ):
        try:
            code = main(argv)
        except SystemExit as end:  # argparse's errors exit; the plan's errors return
            code = end.code  # type: ignore[assignment]
        err = capsys.readouterr().err
        assert code == 2 and says in err and err.count("\n") == 1
