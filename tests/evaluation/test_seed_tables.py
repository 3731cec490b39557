"""Results over training seeds: run scores, the intervals of table.md, P(A > B), and the
refusal of a results directory that mixes a single policy with training seeds."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.seed_tables import (
    check_not_mixed,
    condition_table,
    improvement,
    improvement_table,
    per_seed_table,
    run_of,
    seed_tables,
    success_scores,
    time_scores,
)


def row(method, world, policy_seed, seed, outcome, time_s=10.0, noise="none", **extra):
    return dict(method=method, world=world, policy_seed=policy_seed, seed=seed, noise=noise,
                outcome=outcome, time_s=time_s, tl_m=1.0, pd_rad=0.5, **extra)  # fmt: skip


def learned(world, successes, times=None, eval_seeds=1, method="d3dwa", noise="none"):
    """Rows of one learned method on one world: training seed k reaches the goal in
    successes[k] of its eval_seeds episodes, each taking times[k] s."""
    rows = []
    for k, n_ok in enumerate(successes):
        for s in range(eval_seeds):
            t = 10.0 if times is None else times[k]
            rows.append(row(method, world, k, s, "goal" if s < n_ok else "timeout", t, noise))
    return rows


def cell(table: str, section: str, method_label: str, column: int) -> str:
    """The text of one cell of a table section of seed_tables (column 0 = first world)."""
    part = table.split(section, 1)[1]
    for line in part.splitlines():
        if line.startswith(f"| {method_label} |"):
            return line.split("|")[3 + column].strip()
    raise AssertionError(f"no row {method_label!r} in {section!r}")


def test_runs_are_training_seeds_for_learned_and_eval_seeds_for_fixed():
    assert run_of(row("d3dwa", "TS1", 3, 7, "goal")) == ("train", 3)
    assert run_of(row("dwa3", "TS1", None, 7, "goal")) == ("eval", 7)
    rows = learned("TS1", [2, 0, 1], eval_seeds=2)  # per seed 2/2, 0/2, 1/2
    assert success_scores(rows) == [1.0, 0.0, 0.5]
    rows = learned("TS1", [1, 0, 1], times=[12.0, 99.0, 14.0])
    assert time_scores(rows) == [12.0, 14.0]  # the seed without a success has no time


def test_success_interval_is_the_bootstrap_over_training_seeds_by_hand():
    # Five seeds, four reach the goal: resampling five seeds with replacement gives k/5 with
    # k ~ Binomial(5, 0.8). P(k <= 1) = 0.0067 < 2.5 % < P(k <= 2) = 0.058, and P(k = 5) =
    # 0.33 > 2.5 %, so the 95 % percentile interval is [40 %, 100 %] around 80 %.
    rows = learned("TS1", [1, 1, 0, 1, 1])
    table = seed_tables(rows, ["d3dwa"], ["TS1"])
    assert cell(table, "Success rate", "D3DWA", 0) == "80 [40, 100]"
    # Stratified over two worlds (the second always reached): (k/5 + 1) / 2 -> [70, 100].
    rows += learned("TS2", [1, 1, 1, 1, 1])
    table = seed_tables(rows, ["d3dwa"], ["TS1", "TS2"])
    assert cell(table, "Success rate", "D3DWA", 1) == "100 [100, 100]"
    assert cell(table, "Success rate", "D3DWA", 2) == "90 [70, 100]"


def test_time_is_the_iqm_over_seeds_with_the_exact_bootstrap_interval():
    times = [10.0, 12.0, 14.0, 16.0, 100.0]
    rows = learned("TS1", [1] * 5, times=times)
    table = seed_tables(rows, ["d3dwa"], ["TS1"])
    text = cell(table, "Time to goal", "D3DWA", 0)
    value, low, high = (float(x) for x in text.replace("[", "").replace("]", "").replace(",", "")
                        .split())  # fmt: skip
    assert value == pytest.approx(14.0)  # the middle three of five: (12 + 14 + 16) / 3
    # The exact bootstrap distribution: every one of the 5^5 equally likely resamples.
    exact = sorted(
        float(np.mean(sorted(s)[1:4])) for s in itertools.product(times, repeat=5)
    )  # trim_mean(0.25) of five values drops one from each end
    lo, hi = np.quantile(exact, [0.025, 0.975])
    step = 2.0 / 3.0  # neighbouring IQMs of the grid differ by at least this much
    assert abs(low - lo) <= step and abs(high - hi) <= step


def test_per_seed_table_gives_each_training_seed_its_row():
    rows = learned("TS1", [2, 0], eval_seeds=2) + [
        row("dwa3", "TS1", None, 0, "goal", 11.0),
        row("dwa3", "TS1", None, 1, "collision", 3.0),
    ]
    table = per_seed_table(rows, ["dwa3", "d3dwa"], ["TS1"])
    lines = table.splitlines()[2:]
    assert lines[0].split("|")[2].strip() == "--" and "1/2, 11.0 s" in lines[0]
    assert lines[1].split("|")[2].strip() == "0" and "2/2, 10.0 s" in lines[1]
    assert lines[2].split("|")[2].strip() == "1" and "0/2 (0 C, 2 T)" in lines[2]


def test_a_method_with_a_single_policy_and_seeds_is_refused():
    rows = learned("TS1", [1, 1]) + [row("d3dwa", "TS1", None, 0, "goal")]
    with pytest.raises(ResultsError, match=r"res/results.csv: method 'd3dwa' has rows of a single"):
        check_not_mixed(rows, "res/results.csv")
    check_not_mixed(learned("TS1", [1, 1]) + [row("dwa3", "TS1", None, 0, "goal")], "x")


def groups(r):
    return [r["world"][:2], "all worlds"]


def test_probability_of_improvement_by_hand():
    # A's five seeds always reach the goal, B's never: A always improves on B, surely.
    rows = learned("TS1", [1] * 5) + learned("TS1", [0] * 5, method="d3dwa-weights")
    [ts, total] = improvement(rows, "d3dwa", "d3dwa-weights", groups)
    assert ts["group"] == "TS" and (ts["p"], ts["low"], ts["high"]) == (1.0, 1.0, 1.0)
    assert total["group"] == "all"  # "all worlds" holds the same tasks as "all": left out
    # Against a fixed method's two runs (one goal, one not): P = P(1 > 1)/2 + P(1 > 0) = 0.75.
    rows += [row("dwa3", "TS1", None, 0, "goal"), row("dwa3", "TS1", None, 1, "timeout")]
    [ts, *_] = improvement(rows, "d3dwa", "dwa3", groups)
    assert ts["p"] == pytest.approx(0.75) and ts["runs_a"] == 5 and ts["runs_b"] == 2
    # Per task, then averaged: on US1 A [1, 0] vs B [0.5] gives 0.5; with TS1's 1.0 -> 0.75.
    rows = learned("TS1", [1, 1]) + learned("US1", [1, 0])
    rows += learned("TS1", [0], method="dwa3", eval_seeds=1)
    rows += [row("dwa3", "US1", None, 0, "goal"), row("dwa3", "US1", None, 1, "timeout")]
    for r in rows:  # one fixed "run" averaging two episodes on US1 needs one policy seed
        if r["method"] == "dwa3":
            r["policy_seed"] = 0
    records = {r["group"]: r for r in improvement(rows, "d3dwa", "dwa3", groups)}
    assert records["US"]["p"] == pytest.approx(0.5) and records["TS"]["p"] == 1.0
    assert records["all"]["p"] == pytest.approx(0.75) and records["all"]["tasks"] == 2


def test_improvement_needs_a_shared_task():
    rows = learned("TS1", [1]) + learned("TS2", [1], method="dwa3")
    with pytest.raises(ResultsError, match="share no"):
        improvement(rows, "d3dwa", "dwa3", groups)


def test_a_held_method_against_itself_is_labelled_not_parsed():
    # compare --against keys one method on both sides 'random@10 [A]' / '[B]' and labels them;
    # the keys are not method names and must not be parsed as decision periods
    a, b = "random@10 [A]", "random@10 [B]"
    rows = [row(a, "TS1", None, 0, "goal"), row(b, "TS1", None, 0, "timeout")]
    labels = {a: "Random held 10 steps (filter)", b: "Random held 10 steps"}
    table = improvement_table(improvement(rows, a, b, groups), a, b, labels)
    assert "P(Random held 10 steps (filter) > Random held 10 steps)" in table
    # the labels make it wider than a page: split in two tables, each with the tasks column
    assert "| all | 1 | 1 | 1 |" in table and "| all | 1.00 | [1.00, 1.00] |" in table
    assert all(len(line) <= 120 for line in table.splitlines())
    # two directories' paths in the labels: too long for a column, so A and B name the sides
    long = {a: f"Random held 10 steps ({'runs/' * 12}a)", b: f"Random held 10 steps ({'x/' * 20})"}
    table = improvement_table(improvement(rows, a, b, groups), a, b, long)
    assert "| runs A | runs B | P(A > B) |" in table and "runs/" not in table
    assert all(len(line) <= 120 for line in table.splitlines())


def test_condition_table_averages_the_worlds_of_a_group_per_profile():
    rows = []
    for world, layout in (("R1", "shipped"), ("g1", "generated")):
        rows += [dict(r, layout=layout) for r in learned(world, [1, 1], noise="none")]
        rows += [dict(r, layout=layout) for r in learned(world, [0, 0], noise="harsh")]
    table = condition_table(rows, ["d3dwa"], ["none", "harsh"], lambda r: r["noise"],
                            ["shipped", "generated"], lambda r: r["layout"])  # fmt: skip
    lines = table.splitlines()[2:]
    assert [line.split("|")[2].strip() for line in lines] == ["shipped", "generated", "all layouts"]
    assert all(line.split("|")[3:5] == [" 100 [100, 100] ", " 0 [0, 0] "] for line in lines)


def test_the_runs_column_says_what_a_run_is():
    rows = learned("TS1", [1]) + [row("dwa3", "TS1", None, 0, "goal")]
    rows += [row("dqdwa", "TS1", None, 0, "goal"), row("dqdwa", "TS1", None, 1, "goal")]
    table = seed_tables(rows, ["dwa3", "dqdwa", "d3dwa"], ["TS1"])
    runs = [line.split("|")[2].strip() for line in table.split("### Time")[0].splitlines()
            if line.startswith("| D") and "Method" not in line]  # fmt: skip
    assert runs == ["fixed, 1 episode", "one policy, no training seeds, 2 episodes",
                    "1 training seed, 1 episode"]  # fmt: skip


def test_finer_groups_come_first_and_coarser_ones_follow():
    rows = []
    for world, noise in (("TS1", "none"), ("US1", "none"), ("TS1", "harsh")):
        rows += learned(world, [1, 0], noise=noise) + learned(
            world, [0], method="dwa3", noise=noise
        )

    def by_noise(r):
        return [f"{r['world'][:2]} ({r['noise']})", f"all worlds ({r['noise']})"]

    records = improvement(rows, "d3dwa", "dwa3", by_noise)
    assert [(r["group"], r["tasks"]) for r in records] == [
        ("TS (none)", 1), ("US (none)", 1), ("TS (harsh)", 1), ("all worlds (none)", 2),
        ("all worlds (harsh)", 1), ("all", 3),
    ]  # fmt: skip
    assert all(r["p"] == pytest.approx(0.75) for r in records)  # [1, 0] vs [0]: 1 and 0.5


def test_a_group_sits_at_the_deepest_place_a_row_puts_it():
    # a shipped world has two groups, a generated one three (its style first): the pooled
    # "generated" comes before "all layouts", which a shipped row puts one level higher
    rows = []
    for world in ("R1", "R1-style-s9", "R2-style-s9"):
        rows += learned(world, [1, 0]) + learned(world, [0], method="dwa3")

    def groups(r):
        if r["world"] == "R1":
            return ["shipped", "all layouts"]
        return [r["world"][:8], "generated", "all layouts"]

    records = improvement(rows, "d3dwa", "dwa3", groups)
    assert [(r["group"], r["tasks"]) for r in records] == [
        ("shipped", 1),
        ("R1-style", 1),
        ("R2-style", 1),
        ("generated", 2),
        ("all", 3),
    ]  # fmt: skip  ("all layouts" holds what "all" does: that row says it)
