"""``--suite barn --split --world-ids`` on eval, sweep and worlds: the worlds they choose, the
per-split and per-tercile rows, and one-line refusals before any episode."""

from __future__ import annotations

import csv
import json

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.barn_tables import barn_section
from d3dwa_bullet.evaluation.sweep import given_group
from d3dwa_bullet.world import barn
from d3dwa_bullet.world.barn_difficulty import barn_tercile


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--suite", "barn", "--split", "test"], "--split: unknown split 'test'"),
        (["--suite", "maze"], "--suite: unknown suite 'maze'"),
        (["--suite", "barn", "--world-ids", "300"], "--world-ids: 300 is not a BARN world"),
        (["--suite", "barn", "--world-ids", " , "], "--world-ids is empty"),
        (["--suite", "barn", "--world-ids", "0,1"], "world(s) 1 not in the challenge split"),
        (["--suite", "barn", "--split", "train", "--world-ids", "6"], "6 not in the train split"),
        (["--suite", "barn", "--world-ids", "0,0"], "names a world twice"),
        (["--suite", "barn", "--world-ids", "x"], "'x' is not a world number"),
        (["--split", "train"], "--split needs --suite barn"),
        (["--world-ids", "3"], "--world-ids needs --suite barn"),
        (["--suite", "barn", "--worlds", "R1"], "--worlds and --suite exclude each other"),
    ],
)
@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_bad_suite_input_is_one_line_and_exit_2(command, argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main([command, *argv, "--methods", "dwa3", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("d3dwa: error: ") and message in err[0]
    assert not out.exists()


def test_worlds_lists_the_suite_with_split_and_tercile(capsys):
    assert main(["worlds", "--suite", "barn", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert [r["id"] for r in records] == list(range(300))
    assert sum(r["split"] == "challenge" for r in records) == 50
    assert all(r["tercile"] == barn_tercile(r["id"]) for r in records)
    assert main(["worlds", "--suite", "barn", "--split", "challenge", "--world-ids", "0,6"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split()[0] for ln in lines[2:]] == ["BARN-0", "BARN-6"]
    assert all("challenge" in ln for ln in lines[2:])


def test_eval_runs_the_subset_and_adds_rows_per_tercile(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(barn, "TIME_LIMIT", 2.0)  # short episodes: the test is about the tables
    out = tmp_path / "eval"
    argv = ["eval", "--suite", "barn", "--world-ids", "6", "--methods", "dwa3",
            "--seeds", "1", "--workers", "1", "--out", str(out), "--json"]  # fmt: skip
    assert main(argv) == 0
    with (out / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["world"] for r in rows] == ["BARN-6"] and float(rows[0]["time_s"]) <= 2.0
    table = (out / "table.md").read_text()
    assert "## BARN by split and difficulty" in table
    assert f"| DWA III (2,1,1) | barn-{barn_tercile(6)} |" in table
    assert "barn-challenge" not in table  # one split: no split rows
    capsys.readouterr()
    assert main(argv) == 0  # resumed: nothing to run, same table
    assert (out / "table.md").read_text() == table


def _row(world: str, method: str, seed: int, outcome: str) -> dict:
    return {"world": world, "method": method, "seed": seed, "policy_seed": None, "noise": "none",
            "outcome": outcome, "time_s": 30.0 if outcome == "goal" else 100.0}  # fmt: skip


def test_barn_section_has_rows_per_split_and_tercile():
    worlds = {"BARN-0": "goal", "BARN-1": "collision", "BARN-299": "goal", "R1": "goal"}
    rows = [_row(w, "dwa3", s, o) for w, o in worlds.items() for s in (0, 1)]
    page = barn_section(rows, ["dwa3"], ["none"], lambda r: r["noise"])
    lines = [ln for ln in page.splitlines() if ln.startswith("| DWA")]
    groups = [ln.split("|")[2].strip() for ln in lines]
    terciles = [f"barn-{barn_tercile(i)}" for i in (0, 1, 299)]
    assert groups[:3] == ["barn-challenge", "barn-train", "all layouts"]
    assert set(groups[3:-1]) == set(terciles) and groups[-1] == "all layouts"
    assert lines[0].endswith("| 100 [100, 100] |")  # BARN-0 (challenge) reached its goal
    assert "R1" not in page
    assert barn_section([_row("R1", "dwa3", 0, "goal")], ["dwa3"], ["none"], lambda r: "none") == ""


def test_sweep_groups_barn_worlds_by_tercile_and_runs_no_generated_layouts(tmp_path, capsys):
    out = tmp_path / "sweep"
    argv = ["sweep", "--suite", "barn", "--world-ids", "6", "--methods", "dwa3", "--seeds", "1",
            "--axes", "", "--profiles", "none", "--time-limit", "2", "--workers", "1",
            "--out", str(out), "--json"]  # fmt: skip
    assert main(argv) == 0
    with (out / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [(r["world"], r["layout"]) for r in rows] == [("BARN-6", f"barn-{barn_tercile(6)}")]
    assert (
        f"*barn-{barn_tercile(6)}* = BARN {barn_tercile(6)} tercile: BARN-6"
        in (out / "sweep.md").read_text()
    )
    assert given_group("R1") == "shipped" and given_group("R2-style-s17") == "given"
