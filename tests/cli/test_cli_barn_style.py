"""``--suite barn-style --count N --world-seed S`` on eval, sweep and worlds: the worlds chosen,
their group, and one-line refusals (exit 2) before any episode."""

from __future__ import annotations

import csv
import json

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.sweep import given_group
from d3dwa_bullet.world import barn

FIRST = 2**31


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--suite", "barn-style", "--count", "0"], "--count must be a positive integer"),
        (["--suite", "barn-style", "--count", "-2"], "got -2"),
        (["--suite", "barn-style", "--count", "ten"], "got 'ten'"),
        (["--suite", "barn-style", "--count", "1.5"], "got '1.5'"),
        (["--suite", "barn-style"], "--suite barn-style needs --count"),
        (
            ["--suite", "barn-style", "--count", "2", "--world-seed", "17"],
            "--world-seed 17: BARN-style",
        ),
        (["--suite", "barn-style", "--count", "2", "--world-seed", str(FIRST - 1)], str(FIRST - 1)),
        (["--suite", "barn-style", "--count", "2", "--world-seed", "x"], "got 'x'"),
        (["--suite", "barn-style", "--count", "2", "--split", "train"], "--split does not apply"),
        (["--suite", "barn", "--count", "2"], "--count does not apply to --suite barn"),
        (["--count", "2"], "--count needs --suite barn-style"),
        (["--world-seed", str(FIRST)], "--world-seed needs --suite barn-style"),
    ],
)
@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_bad_barn_style_input_is_one_line_and_exit_2(command, argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main([command, *argv, "--methods", "dwa3", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("d3dwa: error: ") and message in err[0]
    assert not out.exists()


def test_worlds_lists_the_barn_style_worlds_from_the_seed(capsys):
    argv = [
        "worlds",
        "--suite",
        "barn-style",
        "--count",
        "2",
        "--world-seed",
        str(FIRST + 3),
        "--json",
    ]
    assert main(argv) == 0
    records = json.loads(capsys.readouterr().out)
    assert [r["seed"] for r in records] == [FIRST + 3, FIRST + 4]
    assert all(
        r["name"] == f"BARN-style-s{r['seed']}" and r["reference_length"] >= 10.0 for r in records
    )


def test_sweep_rows_are_in_the_barn_style_group_never_barns(tmp_path, monkeypatch):
    monkeypatch.setattr(
        "d3dwa_bullet.world.barn_style.TIME_LIMIT", 2.0
    )  # short: the test is the rows
    out = tmp_path / "sweep"
    argv = ["sweep", "--suite", "barn-style", "--count", "1", "--axes", "", "--profiles", "none",
            "--methods", "dwa3", "--seeds", "1", "--workers", "1", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    with (out / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [(r["world"], r["layout"]) for r in rows] == [(f"BARN-style-s{FIRST}", "barn-style")]
    assert float(rows[0]["time_s"]) <= 2.0 and float(rows[0]["reference_length_m"]) > 0
    page = (out / "sweep.md").read_text()
    assert "BARN-style worlds (not BARN's)" in page and "barn-easy" not in page
    assert given_group(f"BARN-style-s{FIRST}") == "barn-style" and barn.START[1] == 3.0
