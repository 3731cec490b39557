"""A plan's readings (tools/experiments/plan_readings.py): once, on a finished directory, with
the plan's cells and margins; the best fixed DWA chosen per profile by mean score."""

from __future__ import annotations

import json
import re

import pytest

from d3dwa_bullet.evaluation.paired import paired_scores
from d3dwa_bullet.evaluation.readings import reading_of
from d3dwa_bullet.evaluation.results import job_rows, row_key
from d3dwa_bullet.method_specs import method_label
from tests.support.results_logs import write_results
from tools.experiments import plan_readings

LAYOUTS = [f"L{k}" for k in range(12)]
# per method, its score on layout k under each profile: dwa2 beats dwa1 and dwa3 under none,
# dwa3 is best under harsh; "learned" trails dwa2 by 0.2 under none and leads dwa3 under harsh
SCORES = {
    "dwa1": {"none": lambda k: 0.50, "harsh": lambda k: 0.30},
    "dwa2": {"none": lambda k: 0.70 + 0.01 * (k % 3), "harsh": lambda k: 0.20},
    "dwa3": {"none": lambda k: 0.40, "harsh": lambda k: 0.40 + 0.01 * (k % 2)},
    "d3dwa": {"none": lambda k: 0.50 + 0.01 * (k % 3), "harsh": lambda k: 0.60 + 0.01 * (k % 4)},
}


def directory(path, missing: int = 0):
    rows = []
    for m, per in SCORES.items():
        for noise, score in per.items():
            for k, w in enumerate(LAYOUTS):
                rows.append(dict(world=w, method=m, policy_seed=0 if m == "d3dwa" else "", seed=0,
                                 noise=noise, outcome="goal", score=score(k), score_barn=0.1,
                                 layout="custom"))  # fmt: skip
    write_results(path, ((r, {}) for r in rows))
    keys = [list(row_key(r)) for r in job_rows(path)]
    keys += [["L99", "dwa1", None, 0, "none"]] * (missing > 0)
    (path / "meta.json").write_text(json.dumps({"format": 4, "settings": {}, "jobs": keys}))
    return path


def test_best_fixed_is_the_highest_mean_score_per_profile(tmp_path) -> None:
    rows = job_rows(directory(tmp_path / "r"))
    best = plan_readings.best_fixed(rows)
    assert best["none"][0] == "dwa2" and best["harsh"][0] == "dwa3"
    assert best["none"][1] == pytest.approx(0.71)


def test_a_cell_against_best_fixed_reads_against_each_profiles_best(tmp_path, capsys) -> None:
    out = directory(tmp_path / "r")
    assert plan_readings.main([str(out), "--pair", "d3dwa,best-fixed", "--json"]) == 0
    records = {r["profile"]: r for r in json.loads(capsys.readouterr().out)}
    assert records["none"]["b"] == "dwa2" and records["harsh"]["b"] == "dwa3"
    assert records["none"]["readings"]["score"]["reading"] == "B better"
    assert records["harsh"]["readings"]["score"]["reading"] == "A better"
    rows = [r for r in job_rows(out) if r["noise"] == "harsh"]
    expected = reading_of(paired_scores(rows, "d3dwa", "dwa3", by_seed=False, metric="score"), 0.03)
    assert records["harsh"]["readings"]["score"]["difference"] == pytest.approx(
        expected["difference"]
    )
    assert plan_readings.main([str(out), "--pair", "d3dwa,best-fixed"]) == 0
    page = capsys.readouterr().out
    assert "none: `dwa2` (0.710), harsh: `dwa3` (0.405)" in page
    assert all(len(line) <= 120 for line in page.splitlines())


def test_brief_prints_each_cells_readings_per_profile_on_one_line(tmp_path, capsys) -> None:
    out = directory(tmp_path / "r")
    argv = [str(out), "--pair", "d3dwa,best-fixed", "--pair", "d3dwa,dwa1"]
    assert plan_readings.main([*argv, "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert plan_readings.main([*argv, "--brief"]) == 0
    page = capsys.readouterr().out
    score, success = page.split("\n\nSuccess (margin ±3 points)")
    assert score.startswith("Robot score (margin ±0.03)") and "inc.: inconclusive" in success
    short = {"A better": "**A**", "B better": "**B**", "equivalent": "eq.", "inconclusive": "inc."}
    for part, metric in [(score, "score"), (success, "success")]:
        lines = [line for line in part.splitlines() if line.startswith("| ")]
        assert lines[0] == "| A vs B | none | harsh |" and len(lines) == 3
        rows = {line.split(" | ")[0][2:]: line[:-2].split(" | ")[1:] for line in lines[1:]}
        for r in records:
            cell = "`d3dwa` vs " + ("best fixed" if "best_fixed_score" in r else f"`{r['b']}`")
            reading = r["readings"][metric]
            diff = reading["difference"] * (100 if metric == "success" else 1)
            value = f"{diff:+.1f}" if metric == "success" else f"{diff:+.3f}"
            column = 0 if r["profile"] == "none" else 1
            assert rows[cell][column] == f"{short[reading['reading']]} {value}", (cell, metric)
    # d3dwa leads dwa1 by 0-0.02 without noise and by 0.30-0.33 under harsh on every layout
    assert "| `d3dwa` vs `dwa1` | **A** +0.010 | **A** +0.315 |" in score
    assert plan_readings.main([*argv, "--brief", "--json"]) == 2


def test_an_unfinished_directory_and_bad_cells_are_refused(tmp_path, capsys) -> None:
    out = directory(tmp_path / "r", missing=1)
    assert plan_readings.main([str(out), "--pair", "d3dwa,dwa1"]) == 2
    assert "96 of 97 episodes finished" in capsys.readouterr().err
    done = directory(tmp_path / "done")
    for argv, says in [
        (["--plan", "yardstick"], "no rows of method 'd3dwa-weights'"),
        (["--pair", "d3dwa,d3dwa"], "--pair needs two different methods"),
        (["--plan", "barn-trained", "--margin-score", "0.1"], "reads at its own committed margins"),
        ([], "give either --plan or --pair"),
    ]:
        assert plan_readings.main([str(done), *argv]) == 2
        err = capsys.readouterr().err
        assert says in err and len(err.strip().splitlines()) == 1, err


def test_the_plans_cells_are_the_committed_pages() -> None:
    for name, plan in plan_readings.PLANS.items():
        page = (plan_readings.Path(__file__).parents[2] / plan.page).read_text()
        for a, b in plan.pairs:  # every method a cell names is on its plan's page
            for m in (a, b):
                word = re.search(rf"(?<![\w@-]){re.escape(m)}(?![\w@-])", page)
                named = word is not None or method_label(m).split(" (")[0] in page
                assert m == plan_readings.BEST_FIXED or named, (name, m)
    assert plan_readings.PLANS["yardstick"].margins["success"] == 0.05


def test_strata_read_each_barn_tercile_and_style_beside_the_pooled_cell(tmp_path, capsys) -> None:
    worlds = [(f"BARN-{6 * k}", "") for k in range(6)] + [
        (f"R1-style-s{k}", "generated") for k in range(6)
    ]
    rows = []
    for k, (w, layout) in enumerate(worlds):
        layout = layout or "barn-easy"  # a BARN world's tercile group
        for m, score in (("d3dwa", 0.5 + 0.01 * (k % 3) + 0.2 * (k >= 6)), ("dwa1", 0.5)):
            rows.append(dict(world=w, method=m, policy_seed=0 if m == "d3dwa" else "", seed=0,
                             noise="none", outcome="goal", score=score, score_barn=0.1,
                             layout=layout))  # fmt: skip
    out = tmp_path / "r"
    write_results(out, ((r, {}) for r in rows))
    keys = [list(row_key(r)) for r in job_rows(out)]
    (out / "meta.json").write_text(json.dumps({"format": 4, "settings": {}, "jobs": keys}))
    argv = [str(out), "--pair", "d3dwa,dwa1", "--strata"]
    assert plan_readings.main([*argv, "--json"]) == 0
    (record,) = json.loads(capsys.readouterr().out)
    assert list(record["strata"]) == ["barn-easy", "barn", "R1-style", "generated"]
    generated = [r for r in job_rows(out) if r["layout"] == "generated"]
    expected = reading_of(
        paired_scores(generated, "d3dwa", "dwa1", by_seed=False, metric="score"), 0.03
    )
    got = record["strata"]["R1-style"]["score"]
    assert got["layouts"] == 6 and got["difference"] == pytest.approx(expected["difference"])
    assert record["strata"]["barn"]["score"]["difference"] == pytest.approx(0.01)
    assert plan_readings.main(argv) == 0
    page = capsys.readouterr().out
    assert "| `d3dwa` vs `dwa1` | pooled | **A** +0.110 |" in page
    assert "| `d3dwa` vs `dwa1` | generated | **A** +0.210 |" in page
    png = tmp_path / "barn.png"
    assert plan_readings.main([*argv, "--figure", str(png), "--figure-stratum", "barn"]) == 0
    assert png.read_bytes().startswith(b"\x89PNG")


def test_the_figure_is_drawn_pooled_or_for_a_stratum_and_an_unknown_stratum_is_one_line(
    tmp_path, capsys
) -> None:
    out = directory(tmp_path / "r")
    png = tmp_path / "fig" / "readings.png"
    argv = [str(out), "--pair", "d3dwa,dwa1", "--brief", "--figure", str(png)]
    assert plan_readings.main(argv) == 0
    assert png.read_bytes().startswith(b"\x89PNG") and "Robot score" in capsys.readouterr().out
    assert plan_readings.main([*argv, "--figure-stratum", "barn"]) == 2
    err = capsys.readouterr().err
    assert "--figure-stratum 'barn': no such stratum here (present: none)" in err
    assert len(err.strip().splitlines()) == 1
    assert plan_readings.main([str(out), "--pair", "d3dwa,dwa1", "--figure-stratum", "barn"]) == 2
    assert "--figure-stratum needs --figure" in capsys.readouterr().err
