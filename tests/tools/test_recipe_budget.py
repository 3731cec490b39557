"""tools/experiments/recipe_budget.py: a plan's power and cost from variance components."""

from __future__ import annotations

import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.recipe_sizing import Components
from tools.experiments.recipe_budget import budget, cost_hours, main
from tools.experiments.recipe_sizing import named_numbers


def _record(a: str, b: str, difference: float, seed_a: float, family: str = "R-style") -> dict:
    c = Components(difference, seed_a, 0.0, 0.02, 0.0, 0.01, learned=1, fixed=1)
    return {"a": a, "b": b, "profile": "none", "family": family, "components": c.as_dict()}


def test_named_numbers_reads_pairs_and_refuses_bad_values() -> None:
    assert named_numbers(["d3dwa=15", "9"], "--x", default_key="") == {"d3dwa": 15.0, "": 9.0}
    for bad in (["d3dwa=0"], ["d3dwa=nan"], ["d3dwa=x"], ["15"]):
        with pytest.raises(ConfigError, match="--x"):
            named_numbers(bad, "--x")


def test_a_large_effect_reads_early_and_a_null_one_runs_to_the_maximum() -> None:
    records = [_record("d3dwa", "dwa3", 0.2, 0.0001), _record("d3dwa-dr", "dwa3", 0.0, 0.01)]
    out = budget(records, {"d3dwa": 10, "d3dwa-dr": 10}, {"R-style": 400}, 4, 0.03, 0.05, ["dwa3"])
    strong, null = out["cells"]
    assert out["level"] == pytest.approx(0.025)
    assert strong["power"] > 0.99 and strong["read_by_look"][0] > 0.5
    assert null["power"] < 0.2
    runs = out["episodes"][("R-style", "none")]
    fixed_d3dwa, expected_d3dwa = runs["d3dwa"]
    assert (
        fixed_d3dwa == 400 * 10 and expected_d3dwa < 0.5 * fixed_d3dwa
    )  # stops at the first looks
    assert runs["d3dwa-dr"][1] > 0.95 * 400 * 10  # rarely reads: runs to about the maximum
    assert runs["dwa3"][0] == 400  # a fixed method is one run
    hours = cost_hours(out["episodes"], {"R-style": 0.36}, {"d3dwa": 5}, {"": 6.0})
    assert hours["training"] == pytest.approx(0.5)
    assert hours["fixed_episodes"] == pytest.approx((4000 + 4000 + 400) * 0.36 / 3600)
    assert hours["sequential_episodes"] < hours["fixed_episodes"]


def test_bad_input_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    argv = [str(tmp_path), "--plan", "recipes", "--seeds", "d3dwa=10", "--layouts", "Mars=10",
            "--train-minutes", "9", "--episode-seconds", "1"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "Mars" in err and "\n" not in err
