"""The test paired by layout that `d3dwa compare` prints beside P(A > B): its p-value is
scipy.stats.wilcoxon's on the per-(layout, seed) success differences, each side averaged over
its training seeds; no shared layout is refused in one line, one gets a line saying why
there is no test, never a NaN."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

import d3dwa_bullet.cli.compare as compare
from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.floors import floor_records, floor_table
from d3dwa_bullet.evaluation.paired import paired_scores, paired_test, units_for_power

LAYOUTS = [f"L{k}" for k in range(8)]
A_GOALS = {  # (layout, evaluation seed) -> goals of A's three training seeds
    (w, s): [(k + s + t) % 4 != 0 for t in range(3)] for k, w in enumerate(LAYOUTS) for s in (0, 1)
}
B_GOALS = {(w, s): (k + 2 * s) % 3 == 0 for k, w in enumerate(LAYOUTS) for s in (0, 1)}


def row(method: str, world: str, seed: int, goal: bool, policy_seed: int | None) -> dict:
    # noise `real`: without noise a fixed or greedy method's seeds are one episode (repeats)
    return {"method": method, "world": world, "noise": "real", "seed": seed,
            "policy_seed": policy_seed, "outcome": "goal" if goal else "timeout",
            "time_s": 5.0}  # fmt: skip


def constructed() -> list[dict]:
    rows = [row("d3dwa", w, s, g, t) for (w, s), gs in A_GOALS.items() for t, g in enumerate(gs)]
    return rows + [row("dwa1", w, s, g, None) for (w, s), g in B_GOALS.items()]


def expected_p() -> float:
    d = [np.mean(A_GOALS[u]) - float(B_GOALS[u]) for u in sorted(A_GOALS)]
    return float(stats.wilcoxon(d, alternative="greater", zero_method="wilcox").pvalue)


def test_the_paired_p_value_is_scipys_wilcoxon_on_the_differences() -> None:
    scores = paired_scores(constructed(), "d3dwa", "dwa1")
    assert len(scores) == 16 and scores[("L0", "real", 0)] == (2 / 3, 1.0)
    test = paired_test(scores)
    assert test["p"] == pytest.approx(expected_p(), rel=1e-12) and 0.0 < test["p"] < 0.5
    assert test["wins"] + test["losses"] + test["ties"] == 16 and test["wins"] > test["losses"]


def test_compare_prints_scipys_p_value_beside_p_of_improvement(monkeypatch, capsys) -> None:
    rows = constructed()
    monkeypatch.setattr(
        compare,
        "_side",
        lambda out, m, warn=True: ([r for r in rows if r["method"] == m], "none", True),
    )
    assert main(["compare", "made-up", "--methods", "d3dwa,dwa1", "--json"]) == 0
    overall = json.loads(capsys.readouterr().out)["groups"][-1]
    assert overall["group"] == "all" and overall["paired_units"] == 16
    assert overall["paired_p"] == pytest.approx(expected_p(), rel=1e-12)
    assert 0.5 < overall["p"] <= 1.0  # P(A > B), rliable-style, stays beside it
    assert main(["compare", "made-up", "--methods", "d3dwa,dwa1"]) == 0
    printed = capsys.readouterr().out
    assert f"| {expected_p():.3g} |" in printed
    assert "2 evaluation seeds share each layout" in printed  # and points to --pair-by layout


def test_pairing_by_layout_pools_the_evaluation_seeds(monkeypatch, capsys) -> None:
    d = [
        np.mean(A_GOALS[(w, 0)] + A_GOALS[(w, 1)]) - np.mean([B_GOALS[(w, 0)], B_GOALS[(w, 1)]])
        for w in LAYOUTS
    ]
    expected = float(stats.wilcoxon(d, alternative="greater", zero_method="wilcox").pvalue)
    scores = paired_scores(constructed(), "d3dwa", "dwa1", by_seed=False)
    assert len(scores) == 8 and scores[("L0", "real", None)] == (5 / 6, 0.5)
    assert paired_test(scores)["p"] == pytest.approx(expected, rel=1e-12)
    assert expected != pytest.approx(expected_p(), rel=1e-3)  # a different test, not a relabel
    rows = constructed()
    monkeypatch.setattr(
        compare,
        "_side",
        lambda out, m, warn=True: ([r for r in rows if r["method"] == m], "none", True),
    )
    argv = ["compare", "made-up", "--methods", "d3dwa,dwa1", "--pair-by", "layout", "--json"]
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    overall = printed["groups"][-1]
    assert printed["pair_by"] == "layout" and overall["paired_units"] == 8
    assert overall["paired_p"] == pytest.approx(expected, rel=1e-12)
    assert main(argv[:-1]) == 0
    printed = capsys.readouterr().out
    assert (
        "Paired by (layout, noise), each side's success averaged over its training and "
        "evaluation seeds" in printed
    )
    assert "evaluation seeds share each layout" not in printed


def test_no_shared_layout_is_one_line_and_one_layout_prints_why(monkeypatch, capsys) -> None:
    for layouts, code in (([], 2), (["L0"], 0)):
        rows = [r for r in constructed() if r["method"] == "d3dwa" or r["world"] in layouts]
        rows = [r for r in rows if r["method"] == "dwa1" or r["world"] in (layouts or ["L1"])]
        monkeypatch.setattr(
            compare,
            "_side",
            lambda out, m, warn=True, rows=rows: (
                [r for r in rows if r["method"] == m],
                "none",
                True,
            ),
        )
        assert main(["compare", "made-up", "--methods", "d3dwa,dwa1"]) == code
        captured = capsys.readouterr()
        if code:
            err = captured.err.strip().splitlines()
            assert len(err) == 1 and "share no layout: nothing to pair" in err[0]
        else:
            assert "share only one layout (L0); a test paired by layout needs 2" in captured.out
            assert "nan" not in captured.out.lower() and "paired p" not in captured.out


def test_no_difference_is_p_1_and_one_pair_has_no_p() -> None:
    tied = {("L0", "none", 0): (1.0, 1.0), ("L1", "none", 0): (0.0, 0.0)}
    assert paired_test(tied)["p"] == 1.0
    assert paired_test({("L0", "none", 0): (1.0, 0.0)})["p"] is None


def test_the_floor_table_says_which_floor_a_learned_method_cleared() -> None:
    rows = [r | {"method": "random@10"} if r["method"] == "dwa1" else r for r in constructed()]
    rows += [
        r | {"method": "random", "outcome": "timeout"} for r in rows if r["method"] == "random@10"
    ]
    records = floor_records(rows, ["random", "random@10", "d3dwa"])
    assert [(r["floor"], r["cleared"]) for r in records] == [("random", True), ("random@10", True)]
    table = floor_table(records)
    assert "| D3DWA | `random` | 1.00 [" in table and "|  | `random@10` | " in table
    assert table.count("| yes |") == 2 and all(len(line) <= 120 for line in table.splitlines())
    late = [r for r in rows if not (r["method"] == "d3dwa" and r["world"] != "L0")]
    late = [r for r in late if r["method"] != "random@10" or r["world"] != "L0"]
    assert [r["floor"] for r in floor_records(late, ["d3dwa"])] == ["random"]  # no shared task


def test_units_for_power_gives_the_power_it_names_in_simulation() -> None:
    # differences with effect size 0.5: the formula asks for about 25 units; a one-sided
    # t-test on that many draws rejects at 0.05 about 80 % of the time
    rng = np.random.default_rng(0)
    sample = rng.normal(0.5, 1.0, 4000)
    n = units_for_power({("L", "none", i): (x, 0.0) for i, x in enumerate(sample)})
    assert n == pytest.approx((1.6449 + 0.8416) ** 2 / 0.25, rel=0.1)
    k = round(n)
    draws = rng.normal(0.5, 1.0, (4000, k))
    rejected = stats.ttest_1samp(draws, 0.0, axis=1, alternative="greater").pvalue < 0.05
    assert rejected.mean() == pytest.approx(0.80, abs=0.03)
    behind = {("L", "none", i): (0.0, x) for i, x in enumerate(sample[:10])}
    assert units_for_power(behind) == float("inf")  # B ahead: no yardstick finds A > B
    assert units_for_power({("L", "none", 0): (1.0, 0.0)}) is None
