"""The score columns of results rows (docs/design/score.md#score): written on every row, read back
as None from a directory made before the score (and marked so in the tables), and added to
such a directory exactly when eval resumes it."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.episode_metrics import SCORE_FORM
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.report import write_report
from d3dwa_bullet.evaluation.results import (
    RESULTS_FORMAT,
    SCORE_FIELDS,
    UNSCORED_FORMAT,
    read_results,
)
from d3dwa_bullet.evaluation.score_tables import score_condition_tables, score_tables
from d3dwa_bullet.evaluation.scores import UNSCORED_NOTE, score_cells
from d3dwa_bullet.evaluation.seed_tables import per_seed_table
from d3dwa_bullet.world.registry import load_world
from d3dwa_bullet.world.routes import reference_length

OLD_HEADER = ("world,method,policy_seed,seed,noise,outcome,time_s,tl_m,pd_rad,"
              "min_clearance_m,steps")  # fmt: skip
OLD_ROWS = (
    "TS1,dwa1,,0,none,goal,12.3,4.5,0.7,0.21,123",
    "TS1,dwa3,,0,none,collision,4.0,1.2,0.3,-0.01,40",
)


def write_old_eval(out: Path) -> Path:
    """A results directory as the version before the score wrote it (format 3), by hand."""
    out.mkdir()
    (out / "results.csv").write_text("\n".join((OLD_HEADER, *OLD_ROWS)) + "\n")
    jobs = [["TS1", "dwa1", None, 0, "none"], ["TS1", "dwa3", None, 0, "none"]]
    meta = {"format": UNSCORED_FORMAT, "version": "0.9", "config": {},
            "settings": {"kind": "eval", "methods": ["dwa1", "dwa3"], "worlds": ["TS1"],
                         "seeds": [0], "noise": "none"},
            "columns": OLD_HEADER.split(","), "jobs": jobs}  # fmt: skip
    (out / "meta.json").write_text(json.dumps(meta))
    return out


def test_score_cells_by_hand_and_from_the_written_values():
    # L 4 m at 0.4 m/s: t_ref 10 s; BARN t_opt 2 s, clip [4, 16] s
    assert score_cells("goal", 12.5, 4.0, 0.4) == {
        "score": 0.8, "score_barn": 0.16, "reference_length_m": 4.0
    }  # fmt: skip
    assert score_cells("goal", 50.0, 4.0, 0.4)["score_barn"] == 0.125
    assert score_cells("timeout", 60.0, 4.0, 0.4) == {
        "score": 0.0, "score_barn": 0.0, "reference_length_m": 4.0
    }  # fmt: skip
    # L is rounded to 0.1 mm first and the score computed from the rounded value
    cells = score_cells("goal", 20.0, 3.123456, 0.4)
    assert cells["reference_length_m"] == 3.1235
    assert cells["score"] == round(3.1235 / 0.4 / 20.0, 6)


def test_an_old_directory_reads_with_no_score_and_its_tables_say_so(tmp_path):
    out = write_old_eval(tmp_path / "old")
    rows = read_results(out)
    assert [r["outcome"] for r in rows] == ["goal", "collision"]
    assert all(r[c] is None for r in rows for c in SCORE_FIELDS)
    assert UNSCORED_NOTE in score_tables(rows, ["dwa1", "dwa3"], ["TS1"])
    assert "| 100 % | -- | -- |" in per_seed_table(rows, ["dwa1"], ["TS1"])
    report = write_report(out, policies_dir=tmp_path / "no-policies")
    page = " ".join(report.path.read_text().split())  # prose lines split to the page's width
    assert report.complete and UNSCORED_NOTE in page and "Success rate" in page


def test_an_old_directory_with_a_hand_edited_score_cell_is_refused(tmp_path):
    out = write_old_eval(tmp_path / "old")
    lines = (out / "results.csv").read_text().splitlines()
    lines[0] += ",score"
    lines[1] += ",2.5"
    lines[2] += ",0"
    (out / "results.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ResultsError, match="line 2: .*column 'score' is '2.5', not a number"):
        read_results(out)


def test_score_tables_by_hand():
    def row(method, world, seed, score, barn):
        return {"method": method, "world": world, "policy_seed": None, "seed": seed,
                "outcome": "goal" if score else "timeout", "time_s": 10.0,
                "score": score, "score_barn": barn}  # fmt: skip

    rows = [row("dwa1", "A", 0, 0.5, 0.125), row("dwa1", "B", 0, 0.0, 0.0),
            row("dwa3", "A", 0, 1.0, 0.5), row("dwa3", "B", 0, 0.5, 0.25)]  # fmt: skip
    page = score_tables(rows, ["dwa1", "dwa3"], ["A", "B"])
    # one run per world: the value alone (an interval would be its point); all = mean over worlds
    assert "| DWA I (1,1,2) | 0.50 | 0.00 | 0.25 |" in page and "[0.50, 0.50]" not in page
    # mean, IQM of the two runs pooled, BARN mean
    assert "| DWA III (2,1,1) | 0.75 | 0.75 | 0.375 |" in page
    assert max(len(line) for line in page.splitlines()) <= 120
    profiles = score_condition_tables(
        rows, ["dwa3"], ["none"], lambda r: "none", ["g"], lambda r: "g"
    )
    assert "| DWA III (2,1,1) | g | 0.75 |" in profiles
    assert "| DWA III (2,1,1) | g | 0.375 |" in profiles


def eval_args(world: str, out: Path) -> list[str]:
    return ["eval", "--methods", "dwa1,dwa3", "--worlds", world, "--out", str(out),
            "--workers", "1", "--json"]  # fmt: skip


def test_resuming_a_directory_from_before_the_score_scores_its_rows_exactly(
    one_second_world, tmp_path, capsys
):
    out = tmp_path / "run"
    assert main(eval_args(one_second_world, out)) == 0
    capsys.readouterr()
    scored = (out / "results.csv").read_text()
    rows = read_results(out)
    length = reference_length(load_world(one_second_world))
    assert all(r["reference_length_m"] == round(length, 4) for r in rows)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["format"] == RESULTS_FORMAT and meta["settings"]["score_form"] == SCORE_FORM
    # make it a directory from before the score: no score columns, format 3, no score_form
    with (out / "results.csv").open(newline="") as fh:
        table = list(csv.reader(fh))
    keep = [i for i, name in enumerate(table[0]) if name not in SCORE_FIELDS]
    with (out / "results.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows([[line[i] for i in keep] for line in table])
    meta["format"] = UNSCORED_FORMAT
    del meta["settings"]["score_form"]
    (out / "meta.json").write_text(json.dumps(meta))
    assert all(r["score"] is None for r in read_results(out))
    logs = {p.name: p.stat().st_mtime_ns for p in (out / "logs").iterdir()}
    assert main(eval_args(one_second_world, out)) == 0  # resumes: nothing to run
    assert (out / "results.csv").read_text() == scored  # the same bytes as a fresh run
    assert {p.name: p.stat().st_mtime_ns for p in (out / "logs").iterdir()} == logs
    assert json.loads((out / "meta.json").read_text())["format"] == RESULTS_FORMAT


def test_a_directory_scored_in_another_form_is_refused(one_second_world, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(eval_args(one_second_world, out)) == 0
    meta = json.loads((out / "meta.json").read_text())
    meta["settings"]["score_form"] = "kachaka-v0"
    (out / "meta.json").write_text(json.dumps(meta))
    capsys.readouterr()
    assert main(eval_args(one_second_world, out)) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("d3dwa: error:") and "\n" not in err
    assert f"scored in form 'kachaka-v0', this version scores in form '{SCORE_FORM}'" in err


def test_the_iqm_trims_a_quarter_at_each_end_and_the_summary_fits_120_characters():
    scores = {"A": 0.0, "B": 0.2, "C": 0.6, "D": 1.0}
    rows = [
        {"method": "random@10", "world": w, "policy_seed": None, "seed": 0, "outcome": "goal",
         "time_s": 10.0, "score": s, "score_barn": s / 4}
        for w, s in scores.items()
    ]  # fmt: skip
    page = score_tables(rows, ["random@10"], list(scores))
    # mean 0.45; IQM of 0, 0.2, 0.6, 1.0 = mean of 0.2 and 0.6; BARN mean 0.45 / 4
    summary = next(line for line in page.splitlines() if "| 0.40 |" in line)  # one run a world
    assert summary.endswith("| 0.45 | 0.40 | 0.113 |")
    assert len(summary) <= 120  # the longest method label there is
