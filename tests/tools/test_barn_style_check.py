"""tools/experiments/barn_style_check: the two-sample tests, DWA III's success rows, refusals."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from tools.experiments import barn_style_check as check

FIELDS = ["world", "method", "noise", "recovery", "outcome"]


def _results(path, rows):
    path.mkdir(parents=True, exist_ok=True)
    with (path / "results.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(dict(zip(FIELDS, r, strict=True)) for r in rows)
    return path / "results.csv"


def test_two_sample_tells_a_shift_from_the_same_distribution():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=300), rng.normal(size=300)
    same, shifted = check.two_sample(a, b), check.two_sample(a, b + 0.5)
    assert same["ks_p"] > 0.05 and shifted["ks_p"] < 0.001 and shifted["ad_p"] <= 0.001
    assert check.ad_text(0.25) == ">=0.25" and check.ad_text(0.001) == "<=0.001"


def test_success_rows_are_dwa3_without_noise_under_nav2_only(tmp_path):
    rows = [
        ("BARN-style-s2147483648", "dwa3", "none", "nav2", "goal"),
        ("BARN-style-s2147483649", "dwa3", "none", "nav2", "timeout"),
        ("BARN-style-s2147483650", "dwa3", "real", "nav2", "goal"),  # noise: left out
        ("BARN-style-s2147483651", "dwa3", "none", "none", "goal"),  # no layer: left out
        ("BARN-style-s2147483652", "d3dwa", "none", "nav2", "goal"),  # another method
        ("BARN-3", "dwa3", "none", "nav2", "goal"),  # another family
    ]
    assert check.dwa3_outcomes(_results(tmp_path, rows), "BARN-style-") == [True, False]
    s = check.success_comparison([True, False], [True] * 3 + [False])
    assert s["difference_points"] == pytest.approx(-25.0)
    lo, hi = s["difference_newcombe95_points"]
    assert lo < -25.0 < hi and s["style"]["wilson95"][0] < 0.5 < s["style"]["wilson95"][1]


def test_the_tool_writes_its_figure_and_refuses_bad_input(tmp_path, capsys):
    runs = tmp_path / "runs"
    _results(runs, [(f"BARN-style-s{2**31 + i}", "dwa3", "none", "nav2", "goal") for i in range(3)])
    png = tmp_path / "check.png"
    assert check.main(["--count", "3", "--out", str(png), "--runs", str(runs), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report["tests"]) == set(check.MEASURES) and png.stat().st_size > 10_000
    assert report["dwa3_success"]["style"] == {
        "successes": 3,
        "episodes": 3,
        "rate": 1.0,
        "wilson95": report["dwa3_success"]["style"]["wilson95"],
    }
    assert report["dwa3_success"]["barn"]["episodes"] == 300  # the yardstick's dwa3 rows
    for argv, message in ((["--world-seed", "5"], "--world-seed 5"), (["--count", "1"], "--count must be"),
                          (["--out", str(tmp_path / "x.svg")], "not a .png")):  # fmt: skip
        assert check.main(argv) == 2
        assert message in capsys.readouterr().err
