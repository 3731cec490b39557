"""The power plan (tools/experiments/power_plan.py): from a hand-made pilot, the layouts a
difference test and TOST would need, figured from the pilot's per-layout differences."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from scipy import stats

from d3dwa_bullet.evaluation.results import SCORE_FIELDS
from tests.support.results_logs import write_results
from tools.experiments import power_plan

LAYOUTS = [f"L{k}" for k in range(10)]
# per layout, the goals of (A, B) at evaluation seeds 0 and 1, under each profile (noisy ones:
# without noise a fixed method would repeat its episode at both seeds)
GOALS = {
    "harsh": [((True, True), (k % 2 == 0, k % 3 == 0)) for k in range(10)],
    "real": [((k % 4 != 0, True), (True, k % 4 != 1)) for k in range(10)],
}


def pilot(path, methods=("d3dwa", "dwa3")):
    rows = []
    for noise, per in GOALS.items():
        for w, goals in zip(LAYOUTS, per, strict=True):
            for m, seeds in zip(("d3dwa", "dwa3"), goals, strict=True):
                if m not in methods:
                    continue
                rows += [dict(world=w, method=m, policy_seed=0 if m == "d3dwa" else "", seed=s,
                              noise=noise, outcome="goal" if g else "timeout")
                         for s, g in enumerate(seeds)]  # fmt: skip
    write_results(path, ((r, {}) for r in rows), sweep=False)
    # a pilot from before the score (format 3): its results.csv has no score columns
    with (path / "results.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    columns = [c for c in table[0] if c not in SCORE_FIELDS]
    with (path / "results.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(table)
    (path / "meta.json").write_text(json.dumps({"format": 3, "settings": {}, "jobs": []}))
    return path


def differences(noise):
    return np.array([np.mean(a) - np.mean(b) for a, b in GOALS[noise]])


def test_the_plan_is_the_normal_approximation_on_the_pilots_differences(tmp_path, capsys):
    out = pilot(tmp_path / "pilot")
    assert (
        power_plan.main([str(out), "--pair", "d3dwa,dwa3", "--metrics", "success", "--json"]) == 0
    )
    records = {r["profile"]: r for r in json.loads(capsys.readouterr().out)}
    assert set(records) == {"harsh", "real"}
    for noise, r in records.items():
        d = differences(noise)
        assert r["layouts"] == 10 and r["difference"] == pytest.approx(d.mean(), rel=1e-12)
        assert r["sd"] == pytest.approx(d.std(ddof=1), rel=1e-12)
    z = stats.norm.ppf(0.975) + stats.norm.ppf(0.8)
    d = differences("harsh")  # A far ahead: the difference test decides first
    assert records["harsh"]["needed_difference"] == math.ceil((z * d.std(ddof=1) / d.mean()) ** 2)
    assert records["harsh"]["aim"] == "A better" and records["harsh"]["needed_equivalence"] is None
    real = records["real"]  # level on average: TOST against 3 points decides first
    assert real["difference"] == 0.0 and real["aim"] == "equivalent"
    assert real["needed"] == real["needed_equivalence"] > 10
    assert power_plan.main([str(out), "--pair", "d3dwa,dwa3", "--margin-success", "10"]) == 0
    printed = capsys.readouterr().out
    line = next(x for x in printed.splitlines() if "| real | success" in x)
    assert "equivalent within ±10 points:" in line
    needed = int(line.rsplit(": ", 1)[1].split()[0])
    assert 2 <= needed < real["needed"]
    assert "no score: results from before the score" in printed  # the pilot has no score


def test_the_score_plans_from_rows_that_carry_it() -> None:
    rows = [{"method": m, "world": w, "noise": "harsh", "seed": 0, "policy_seed": None,
             "outcome": "goal", "score": s, "score_barn": s / 4}
            for k, w in enumerate(LAYOUTS)
            for m, s in (("a", 0.5 + 0.01 * (k % 3)), ("b", 0.45 + 0.01 * (k % 2)))]  # fmt: skip
    records = power_plan.plan(rows, [("a", "b")], {"score": 0.03, "score_barn": 0.01})
    score = next(r for r in records if r["metric"] == "score")
    d = np.array([0.05 + 0.01 * (k % 3) - 0.01 * (k % 2) for k in range(10)])
    assert score["difference"] == pytest.approx(d.mean()) and score["aim"] == "A better"
    assert score["needed"] == score["needed_difference"] >= 2


def test_bad_pilots_and_pairs_are_one_line(tmp_path, capsys):
    out = pilot(tmp_path / "pilot")
    also = pilot(tmp_path / "also", methods=("dwa3",))
    cases = [
        ([str(out), "--pair", "d3dwa,dwa9"], "no rows of method 'dwa9'"),
        ([str(out), "--pair", "d3dwa"], "--pair needs two different methods A,B"),
        ([str(out), "--pair", "d3dwa,dwa3", "--margin-barn", "nan"], "--margin-barn must be"),
        ([str(out), "--pair", "d3dwa,dwa3", "--metrics", "speed"], "--metrics: speed is not"),
        ([str(out), "--also", str(also), "--pair", "d3dwa,dwa3"], "'dwa3' is also in"),
        ([str(tmp_path), "--pair", "d3dwa,dwa3"], "not a results directory"),
    ]
    for argv, says in cases:
        assert power_plan.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("power_plan: error: ") and says in err and "\n" not in err
