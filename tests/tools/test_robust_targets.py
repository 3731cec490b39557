"""Issue 40's targets read from sweeps: each met or missed as the issue fixed it."""

from __future__ import annotations

import pytest

from tests.support.results_logs import write_results
from tools.experiments import robust_targets

LAYOUTS = [f"L{i}" for i in range(6)]


def rows(method, noise, goals, policy_seed=""):
    """goals: the layouts (indices) where the episode reaches the goal."""
    axis = "none" if noise == "none" else "profile"
    return [dict(world=w, method=method, policy_seed=policy_seed, noise=noise, axis=axis,
                 outcome="goal" if i in goals else "timeout") for i, w in enumerate(LAYOUTS)]  # fmt: skip


def sweep(tmp_path, dr_seed1_harsh=range(6)):
    every, half = range(6), range(3)
    out = []
    for noise in ("none", "real", "harsh"):
        out += rows("dwa3", noise, every) + rows("random@10", noise, ())
        for k in (0, 1):
            out += rows("d3dwa", noise, half, k)
        out += rows("d3dwa-dr", noise, every, 0)
        out += rows("d3dwa-dr", noise, dr_seed1_harsh if noise == "harsh" else every, 1)
    return write_results(tmp_path, ((r, {}) for r in out))


def test_a_method_that_wins_everywhere_meets_every_target(tmp_path):
    records = robust_targets.targets([sweep(tmp_path)], "d3dwa-dr")
    assert len(records) == 10 and all(r["met"] for r in records)
    beats = next(r for r in records if r["target"].startswith("beats d3dwa"))
    # ties on L0-L2, wins on L3-L5 whatever the resample: P = 0.75 exactly
    assert beats["p"] == pytest.approx(0.75) and beats["low"] == pytest.approx(0.75)
    floor = [r for r in records if r["target"].startswith("above random@10")]
    assert [r["p"] for r in floor] == pytest.approx([1 / 64] * 3)  # six layouts each won


def test_a_seed_failing_harsh_misses_success_and_dwa3_not_the_moonshot(tmp_path, capsys):
    out = sweep(tmp_path, dr_seed1_harsh=range(3, 6))
    records = {(r["profile"], r["target"]): r for r in robust_targets.targets([out], "d3dwa-dr")}
    harsh = records[("harsh", "success >= 88%")]
    assert harsh["success"] == pytest.approx(0.75) and not harsh["met"]
    moonshot = next(r for (p, _), r in records.items() if p == "all")
    assert moonshot["met"] and moonshot["worst_per_seed"] == {0: 1.0, 1: 0.5}
    assert robust_targets.main([str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| harsh | success >= 88% | 75.0% [" in printed and "8 of 10 targets met." in printed
    missed = [k for k, r in records.items() if not r["met"]]
    assert missed == [("harsh", "not below dwa3 (P upper end >= 0.5)"), ("harsh", "success >= 88%")]


def test_a_missing_method_is_one_line(tmp_path, capsys):
    out = sweep(tmp_path)
    assert robust_targets.main([str(out), "--method", "d3dwa-history-dr"]) == 2
    err = capsys.readouterr().err.strip()
    assert "no rows of 'd3dwa-history-dr' under profile 'none'" in err and "\n" not in err


def test_the_switch_is_read_as_one_candidate_with_the_fixed_planner_in_every_seed(tmp_path, capsys):
    out = sweep(tmp_path)
    switch = {"none": "d3dwa", "real": "d3dwa", "harsh": "dwa3"}
    records = robust_targets.targets([out], "headroom", switch=switch)
    harsh = next(r for r in records if r["target"] == "success >= 88%")
    assert harsh["success"] == 1.0  # DWA III's goals on every layout
    moonshot = records[-1]
    # d3dwa's seeds reach 50 % under none and real; DWA III's one run counts for both seeds
    assert moonshot["worst_per_seed"] == {0: 0.5, 1: 0.5} and not moonshot["met"]
    floor = next(r for r in records if r["profile"] == "none" and "random@10" in r["target"])
    # differences 1, 1, 1, 0, 0, 0: ((1.645 + 0.842) x 0.548 / 0.5)^2 = 7.4 -> 8 layouts
    assert floor["units_for_power"] == pytest.approx(7.42, abs=0.01)
    assert "80 % power needs 8 layouts" in floor["measured"]
    fixed = robust_targets.targets([out], "dwa3")[-1]
    assert fixed["worst_per_seed"] == {None: 1.0}
    assert robust_targets.main([str(out), "--switch", "none=d3dwa"]) == 2
    assert "--switch names no method for profile real, harsh" in capsys.readouterr().err
    assert robust_targets.main([str(out), "--method", "dwa3", "--switch", "none=d3dwa"]) == 2
    assert "--method and --switch name two candidates" in capsys.readouterr().err
