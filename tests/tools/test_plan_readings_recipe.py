"""plan_readings' two questions (--question), its per-family page (--families, Holm) and the
recipe sizing tool, on hand-made finished directories (issue 77)."""

from __future__ import annotations

import json

from d3dwa_bullet.evaluation.results import job_rows, row_key
from tests.support.results_logs import write_results
from tools.experiments import plan_readings, recipe_sizing

BARN = [(f"BARN-{6 * k}", "barn-easy") for k in range(8)]
R_STYLE = [(f"R1-style-s{k}", "generated") for k in range(8)]


def directory(path, seeds=(0, 1, 2)):
    """d3dwa (training seeds `seeds`) against dwa1 under `none`. On BARN the seeds disagree
    (0.3, 0.5, 0.7 above dwa1's 0.4, a small layout wobble): these policies read A better, the
    recipe cannot. On R-style every seed is 0.2 above dwa1: both read A better."""
    rows = []
    for k, (w, layout) in enumerate(BARN + R_STYLE):
        barn = layout != "generated"
        rows.append(dict(world=w, method="dwa1", policy_seed="", seed=0, noise="none", outcome="goal",
                         score=0.4 + 0.01 * (k % 3), score_barn=0.1, layout=layout))  # fmt: skip
        for i, s in enumerate(seeds):
            score = (0.3 + 0.2 * i if barn else 0.6 + 0.005 * i) + 0.01 * (k % 4)
            rows.append(dict(world=w, method="d3dwa", policy_seed=s, seed=0, noise="none", outcome="goal",
                             score=score, score_barn=0.1, layout=layout))  # fmt: skip
    write_results(path, ((r, {}) for r in rows))
    keys = [list(row_key(r)) for r in job_rows(path)]
    (path / "meta.json").write_text(json.dumps({"format": 4, "settings": {}, "jobs": keys}))
    return path


def test_families_read_both_questions_per_family_with_holm(tmp_path, capsys):
    argv = [str(directory(tmp_path / "r")), "--pair", "d3dwa,dwa1", "--families"]
    assert plan_readings.main([*argv, "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    score = {(r["family"], r["question"]): r for r in records if r["metric"] == "score"}
    assert set(score) == {
        (f, q) for f in ("BARN", "R-style", "pooled") for q in ("policies", "recipe")
    }
    assert score[("BARN", "policies")]["reading"] == "A better"
    assert score[("BARN", "recipe")]["reading"] == "inconclusive"
    assert score[("R-style", "recipe")]["reading"] == "A better"
    assert (
        score[("BARN", "recipe")]["layouts"] == 8 and score[("pooled", "recipe")]["layouts"] == 16
    )
    assert score[("BARN", "recipe")]["adjusted"] == "Holm over 2"  # one cell x two families
    assert score[("pooled", "recipe")]["adjusted"] is None
    assert plan_readings.main(argv) == 0
    page = capsys.readouterr().out
    assert "**the recipe (training seed random)**: score" in page
    assert "Holm-adjusted (Holm over 2 tests)" in page and "p-values unadjusted (secondary)" in page
    assert "| A vs B | profile | BARN (8 layouts) | R-style (8 layouts) |" in page


def test_a_cell_prints_both_questions_each_saying_which(tmp_path, capsys):
    out = str(directory(tmp_path / "r"))
    assert plan_readings.main([out, "--pair", "d3dwa,dwa1"]) == 0
    printed = capsys.readouterr().out
    assert printed.index("**These policies** (training seeds fixed)") < printed.index(
        "**The recipe**"
    )
    assert plan_readings.main([out, "--pair", "d3dwa,dwa1", "--question", "policies"]) == 0
    assert "The recipe" not in capsys.readouterr().out
    assert plan_readings.main([out, "--pair", "d3dwa,dwa1", "--question", "recipe", "--json"]) == 0
    (record,) = json.loads(capsys.readouterr().out)
    assert record["recipe"]["score"]["seeds_a"] == 3 and record["recipe_why"] is None


def test_a_learned_side_with_one_seed_is_refused_at_the_recipe_level(tmp_path, capsys):
    out = str(directory(tmp_path / "r", seeds=(4,)))
    for extra in (["--question", "recipe"], ["--families"]):
        assert plan_readings.main([out, "--pair", "d3dwa,dwa1", *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "method 'd3dwa' has one training seed (4)" in err[0]
    assert plan_readings.main([out, "--pair", "d3dwa,dwa1"]) == 0  # both: says why, reads policies
    assert "not read: method 'd3dwa' has one training seed (4)" in " ".join(
        capsys.readouterr().out.split()
    )


def test_recipe_sizing_prints_a_design_per_family_and_refuses_bad_costs(tmp_path, capsys):
    out = str(directory(tmp_path / "r"))
    argv = [out, "--pair", "d3dwa,dwa1", "--train-minutes", "9", "--episode-seconds", "1.0"]
    assert recipe_sizing.main([*argv, "--json"]) == 0
    records = {r["family"]: r for r in json.loads(capsys.readouterr().out)}
    assert set(records) == {"BARN", "R-style"}
    assert (
        records["BARN"]["components"]["seed_a"] > 100 * records["R-style"]["components"]["seed_a"]
    )
    assert records["R-style"]["design"]["power"] >= 0.8
    assert records["BARN"]["design"]["seeds"] >= records["R-style"]["design"]["seeds"]
    assert recipe_sizing.main(argv) == 0
    assert "| `d3dwa` vs `dwa1` | none | BARN |" in capsys.readouterr().out
    for bad, says in ((["--episode-seconds", "BARN=-1"], "positive finite"),
                      (["--episode-seconds", "Mars=1"], "unknown family"),
                      (["--train-minutes", "nan"], "--train-minutes")):  # fmt: skip
        base = [out, "--pair", "d3dwa,dwa1", "--train-minutes", "9", "--episode-seconds", "1"]
        assert recipe_sizing.main([*base, *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0]
    one = str(directory(tmp_path / "one", seeds=(2,)))
    assert recipe_sizing.main([one, *argv[1:]]) == 2
    assert "has one training seed (2)" in capsys.readouterr().err


def test_families_figure_draws_the_recipe_per_family(tmp_path, capsys):
    out = str(directory(tmp_path / "r"))
    png = tmp_path / "recipe.png"
    assert (
        plan_readings.main([out, "--pair", "d3dwa,dwa1", "--families", "--figure", str(png)]) == 0
    )
    for family in ("barn", "r-style"):
        drawn = tmp_path / f"recipe_{family}.png"
        assert drawn.stat().st_size > 10_000
