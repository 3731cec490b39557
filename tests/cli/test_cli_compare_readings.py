"""`d3dwa compare`'s readings (docs/design/readings.md#readings) and what it prints when the two sides
share one layout (issue 58 item 2): hand-made results directories, no episode run."""

from __future__ import annotations

import json

import pytest

import d3dwa_bullet.cli.compare as compare
from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.paired import paired_scores
from d3dwa_bullet.evaluation.readings import reading_of
from d3dwa_bullet.world.barn import barn_index
from d3dwa_bullet.world.barn_difficulty import barn_tercile_group
from tests.support.cli import refused
from tests.support.results_logs import write_results


def results_dir(path, layouts, methods=("dwa3", "dwa1"), settings=None):
    """A results directory (eval's columns) of fixed methods on layouts, two evaluation seeds
    each; dwa3 reaches the goal where (k + seed) % 3, dwa1 where (k + seed) % 2 (under noise
    `real`: without noise a fixed method runs one episode for every seed)."""
    rows = []
    for k, w in enumerate(layouts):
        for s in (0, 1):
            for m, mod in zip(methods, (3, 2), strict=False):
                rows.append(dict(world=w, method=m, policy_seed="", seed=s, noise="real",
                                 outcome="goal" if (k + s) % mod else "timeout", time_s=5.0 + k))  # fmt: skip
    write_results(path, ((r, {}) for r in rows), sweep=False)
    meta = {"format": 3, "settings": dict(settings or {}), "jobs": []}
    (path / "meta.json").write_text(json.dumps(meta))
    return path


def test_one_shared_layout_prints_what_it_can_and_why_the_paired_test_is_absent(tmp_path, capsys):
    out = results_dir(tmp_path / "one", ["L0"])
    assert main(["compare", str(out), "--methods", "dwa3,dwa1"]) == 0
    printed = capsys.readouterr().out
    assert "| all | 1 | 2 | 2 | 0.50 | [0.00, 1.00] |" in printed  # P(A > B) over runs
    assert "### Success rate [%]" in printed and "### Time to goal" in printed
    assert "| DWA III (2,1,1) | fixed, 2 episodes | 50 [0, 100] |" in printed
    absent = [line for line in printed.splitlines() if line.startswith("No paired test")]
    assert absent == [
        "No paired test: methods 'dwa3' and 'dwa1' share only one layout (L0); a test paired by "
        "layout needs 2 or more."
    ]
    assert "Wilcoxon" not in printed and "Readings" not in printed and "nan" not in printed
    assert main(["compare", str(out), "--methods", "dwa3,dwa1", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["no_paired_test"] == absent[0] and record["groups"][-1]["p"] == 0.5
    assert "readings" not in record["groups"][-1]


def test_the_cross_track_command_works_with_one_world(tmp_path, capsys):
    rec = results_dir(tmp_path / "rec", ["L0"], ("dwa3",))
    paper = results_dir(tmp_path / "paper", ["L0"], ("dwa3",))
    argv = ["compare", str(rec), "--against", str(paper), "--methods", "dwa3,dwa3"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    words = " ".join(printed.split())  # prose lines split to the page's width
    assert f"From {rec / 'results.csv'} and {paper / 'results.csv'}." in words
    assert "share only one layout (L0)" in printed


def test_no_shared_layout_is_still_refused_in_one_line(tmp_path, capsys):
    a = results_dir(tmp_path / "a", ["L0"], ("dwa3",))
    b = results_dir(tmp_path / "b", ["L1"], ("dwa1",))
    assert main(["compare", str(a), "--against", str(b), "--methods", "dwa3,dwa1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "share no" in err


def test_two_score_forms_are_refused_naming_both(tmp_path, capsys):
    a = results_dir(tmp_path / "a", ["L0", "L1"], ("dwa3",), {"score_form": "kachaka-v1"})
    b = results_dir(tmp_path / "b", ["L0", "L1"], ("dwa3",), {"score_form": "kachaka-v2"})
    assert main(["compare", str(a), "--against", str(b), "--methods", "dwa3,dwa3"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'kachaka-v1'" in err and "'kachaka-v2'" in err
    same = results_dir(tmp_path / "c", ["L0", "L1"], ("dwa3",), {"score_form": "kachaka-v1"})
    assert main(["compare", str(a), "--against", str(same), "--methods", "dwa3,dwa3"]) == 0


@pytest.mark.parametrize(
    ("option", "value"),
    [("--margin-success", "0"), ("--margin-score", "nan"), ("--margin-barn", "-0.01"),
     ("--margin-score", "inf"), ("--margin-success", "150")],
)  # fmt: skip
def test_a_margin_that_is_not_a_positive_finite_number_is_refused_first(option, value, capsys):
    # the directory does not exist: the margin is refused before anything is read
    assert main(["compare", "no-such-dir", "--methods", "dwa3,dwa1", option, value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"d3dwa: error: {option} must be a positive finite number")
    assert "\n" not in err and "no-such-dir" not in err


def scored_rows(with_score=True):
    """A on eight layouts a little faster than B (score) and as often at the goal."""
    rows = []
    for k in range(8):
        for s in (0, 1):
            for m, base in (("d3dwa", 0.52), ("dwa3", 0.45)):
                goal = (k + s) % 4 != 0
                score = (base + 0.01 * ((k * 7 + s) % 5)) if goal else 0.0
                row = {"method": m, "world": f"L{k}", "noise": "none", "seed": s,
                       "policy_seed": 0 if m == "d3dwa" else None,
                       "outcome": "goal" if goal else "timeout", "time_s": 5.0}  # fmt: skip
                if with_score:
                    row |= {"score": score, "score_barn": score / 4}
                rows.append(row)
    return rows


def side_of(rows):
    return lambda out, m, warn=True: ([r for r in rows if r["method"] == m], "none", True)


def test_compare_reads_success_and_both_scores_as_the_readings_module_does(monkeypatch, capsys):
    rows = scored_rows()
    monkeypatch.setattr(compare, "_side", side_of(rows))
    assert main(["compare", "made-up", "--methods", "d3dwa,dwa3", "--json"]) == 0
    overall = json.loads(capsys.readouterr().out)["groups"][-1]
    for metric, margin in (("success", 0.03), ("score", 0.03), ("score_barn", 0.01)):
        expected = reading_of(paired_scores(rows, "d3dwa", "dwa3", False, metric), margin)
        got = overall["readings"][metric]
        assert got["reading"] == expected["reading"] and got["layouts"] == 8
        assert got["difference"] == pytest.approx(expected["difference"], rel=1e-12)
        assert got["tost_p"] == pytest.approx(expected["tost_p"], rel=1e-12)
    assert overall["readings"]["success"]["reading"] == "equivalent"  # the same goals
    assert overall["readings"]["score"]["reading"] == "A better"
    assert main(["compare", "made-up", "--methods", "d3dwa,dwa3", "--margin-success", "0.5"]) == 0
    printed = capsys.readouterr().out
    assert "| all | success (±0.5 points) | 8 | 75.0 | 75.0 | +0.0 [+0.0, +0.0] |" in printed
    assert "| all | score (±0.03) | 8 |" in printed and "| A better |" in printed
    assert "no score" not in printed


def test_results_from_before_the_score_read_on_success_alone(monkeypatch, capsys):
    monkeypatch.setattr(compare, "_side", side_of(scored_rows(with_score=False)))
    assert main(["compare", "made-up", "--methods", "d3dwa,dwa3"]) == 0
    printed = capsys.readouterr().out
    assert "| all | success (±3 points) | 8 |" in printed and "| all | score (" not in printed
    lines = [line for line in printed.splitlines() if "no score" in line]
    assert lines == [
        "score and BARN official score: no score: results from before the score; success reads "
        "alone."
    ]


def test_an_eval_of_barn_worlds_is_compared_per_difficulty_tercile(tmp_path, capsys):
    worlds = ["BARN-0", "BARN-6", "BARN-12"]
    out = results_dir(tmp_path / "barn", worlds)
    assert main(["compare", str(out), "--methods", "dwa3,dwa1"]) == 0
    printed = capsys.readouterr().out
    groups = {barn_tercile_group(barn_index(w)) for w in worlds}
    assert all(f"| {g}, noise real |" in printed for g in groups)
    assert "| custom, noise real |" not in printed


def sweep_dir(path, layouts):
    """A sweep's results directory (its layout column): dwa3 and dwa1 on (world, group) pairs,
    as results_dir's rule decides their outcomes."""
    rows = []
    for k, (w, group) in enumerate(layouts):
        for s in (0, 1):
            for m, mod in (("dwa3", 3), ("dwa1", 2)):
                rows.append(dict(world=w, layout=group, axis="profile", level="", method=m,
                                 policy_seed="", seed=s, noise="real",
                                 outcome="goal" if (k + s) % mod else "timeout", time_s=5.0 + k))  # fmt: skip
    write_results(path, ((r, {}) for r in rows))
    (path / "meta.json").write_text(json.dumps({"format": 3, "settings": {}, "jobs": []}))
    return path


def test_a_sweep_of_several_styles_is_read_per_style_then_pooled(tmp_path, capsys):
    layouts = [("R1", "shipped")] + [
        (f"R{i}-style-s{k}", "generated") for i in (1, 2) for k in (1, 2, 3)
    ]
    out = sweep_dir(tmp_path / "styles", layouts)
    assert main(["compare", str(out), "--methods", "dwa3,dwa1", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)["groups"]
    assert [(r["group"], r["tasks"]) for r in records] == [
        ("shipped, noise real", 1), ("R1-style, noise real", 3), ("R2-style, noise real", 3),
        ("generated, noise real", 6), ("all", 7),
    ]  # fmt: skip
    assert records[1]["readings"]["success"]["layouts"] == 3
    one = sweep_dir(tmp_path / "one", [(f"R1-style-s{k}", "generated") for k in (1, 2, 3)])
    assert main(["compare", str(one), "--methods", "dwa3,dwa1", "--json"]) == 0
    groups = [r["group"] for r in json.loads(capsys.readouterr().out)["groups"]]
    assert groups == ["generated, noise real", "all"]  # one style: its stratum is the pool


def test_a_sweep_of_barn_and_generated_layouts_pools_barn_beside_generated(tmp_path, capsys):
    barn = [(w, barn_tercile_group(barn_index(w))) for w in ("BARN-0", "BARN-6", "BARN-12")]
    generated = [(f"R1-style-s{k}", "generated") for k in (1, 2)]
    out = sweep_dir(tmp_path / "mixed", barn + generated)
    assert main(["compare", str(out), "--methods", "dwa3,dwa1", "--json"]) == 0
    records = {r["group"]: r for r in json.loads(capsys.readouterr().out)["groups"]}
    assert (
        records["barn, noise real"]["tasks"] == 3 and records["generated, noise real"]["tasks"] == 2
    )
    assert records["barn, noise real"]["readings"]["success"]["layouts"] == 3
    only = sweep_dir(tmp_path / "barn", barn)  # BARN alone: its pool is "all layouts"
    assert main(["compare", str(only), "--methods", "dwa3,dwa1", "--json"]) == 0
    groups = [r["group"] for r in json.loads(capsys.readouterr().out)["groups"]]
    assert "barn, noise real" not in groups and groups[-1] == "all"


def test_a_duplicated_row_is_refused_by_compare_and_report_never_counted_twice(tmp_path, capsys):
    out = results_dir(tmp_path / "dup", ["L0", "L1", "L2"])
    lines = (out / "results.csv").read_text().splitlines(keepends=True)
    (out / "results.csv").write_text("".join([*lines, lines[3]]))
    said = f"line {len(lines) + 1} repeats the episode of line 4"
    assert said in refused(capsys, "compare", out, "--methods", "dwa3,dwa1")
    assert said in refused(capsys, "report", out)


def test_against_on_one_shared_layout_reads_inconclusive_and_says_why(tmp_path, capsys):
    a = results_dir(tmp_path / "a", ["L0"])
    b = results_dir(tmp_path / "b", ["L0"])
    assert main(["compare", str(a), "--against", str(b), "--methods", "dwa3,dwa3"]) == 0
    printed = capsys.readouterr().out
    words = " ".join(printed.split())
    assert "inconclusive" in words and "share only one layout (L0)" in words
