"""Each method's means per profile (tools/experiments/method_means.py): a layout's episodes
averaged first, then the layouts; "--" where a method did not run; no score, no score cell."""

from __future__ import annotations

import csv
import json

import pytest

from d3dwa_bullet.evaluation.results import SCORE_FIELDS, UNSCORED_FORMAT, job_rows, row_key
from tests.support.results_logs import write_results
from tools.experiments import method_means


def directory(path, rows, missing: int = 0):
    write_results(path, ((r, {}) for r in rows))
    keys = [list(row_key(r)) for r in job_rows(path)]
    keys += [["L99", "dwa1", None, 0, "none"]] * missing
    (path / "meta.json").write_text(json.dumps({"format": 4, "settings": {}, "jobs": keys}))
    return path


def row(world, method, seed, noise, goal, score=0.5, barn=0.1):
    return dict(world=world, method=method, policy_seed=seed, seed=0, noise=noise,
                outcome="goal" if goal else "collision", score=score, score_barn=barn,
                layout="custom")  # fmt: skip


def test_layouts_are_averaged_after_their_seeds(tmp_path, capsys) -> None:
    # d3dwa: layout L0 four seeds, three reach the goal (0.75); L1 one seed, fails (0.0):
    # by layout 37.5 %, where pooling the five episodes would give 60 %
    rows = [row("L0", "d3dwa", k, "none", k < 3, score=0.8) for k in range(4)]
    rows += [row("L1", "d3dwa", 0, "none", False, score=0.0, barn=0.0)]
    rows += [row(w, "dwa1", "", "real", True, score=0.6, barn=0.2) for w in ("L0", "L1")]
    out = directory(tmp_path / "r", rows, missing=1)
    means = method_means.method_means(job_rows(out))
    assert means["d3dwa"]["none"]["success"] == pytest.approx(0.375)
    assert means["d3dwa"]["none"]["score"] == pytest.approx(0.4)
    assert means["d3dwa"]["none"]["score_barn"] == pytest.approx(0.05)
    assert "real" not in means["d3dwa"] and means["dwa1"]["real"]["layouts"] == 2
    assert method_means.main([str(out)]) == 0
    page = capsys.readouterr().out
    assert page.startswith("7 of 8 listed episodes in; 2 layouts a cell.")
    assert "| `d3dwa` | 37.5, 0.400 (0.050) | -- |" in page
    assert "| `dwa1` | -- | 100.0, 0.600 (0.200) |" in page


def test_a_cell_without_the_score_shows_success_alone(tmp_path, capsys) -> None:
    out = directory(tmp_path / "r", [row("L0", "dwa1", "", "none", True)])
    # a directory from before the score: no score columns, its format
    with (out / "results.csv").open(newline="") as fh:
        table = list(csv.reader(fh))
    keep = [i for i, name in enumerate(table[0]) if name not in SCORE_FIELDS]
    with (out / "results.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows([[line[i] for i in keep] for line in table])
    meta = json.loads((out / "meta.json").read_text())
    (out / "meta.json").write_text(json.dumps(meta | {"format": UNSCORED_FORMAT}))
    assert method_means.main([str(out), "--json"]) == 0
    cell = json.loads(capsys.readouterr().out)["means"]["dwa1"]["none"]
    assert cell["success"] == 1.0 and cell["score"] is None
    assert method_means.main([str(out)]) == 0
    assert "| `dwa1` | 100.0 |" in capsys.readouterr().out
    assert method_means.main([str(tmp_path / "nowhere")]) == 2
