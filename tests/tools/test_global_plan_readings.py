"""tools/experiments/global_plan_readings: matched collision rates, the moonshot's cells, refusals."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from d3dwa_bullet.evaluation.job import log_name
from d3dwa_bullet.evaluation.results import CSV_FIELDS
from tools.experiments import global_plan_readings as gpr


def _row(world, outcome, noise="none", plan=None, method="dwa3", policy_seed=""):
    row = dict.fromkeys(CSV_FIELDS, "0")
    row.update(
        world=world, method=method, policy_seed=policy_seed, seed="0", noise=noise, outcome=outcome
    )
    row.update(time_s="30.0", tl_m="10.0", pd_rad="1.0", min_clearance_m="0.2", steps="300")
    row.update(score="0.7", score_barn="0.2", reference_length_m="10.0")
    if plan is not None:
        row["global_plan"] = plan
    return row


def _results(path, rows):
    path.mkdir(parents=True)
    fields = list(rows[0])
    with (path / "results.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    return path


def test_families_labels_and_plans():
    assert gpr.family_of("BARN-12") == "BARN" and gpr.family_of("R2-style-s2147543648") == "R-style"
    assert (
        gpr.family_of("TS4") == "TS4"
        and gpr.family_of("BARN-style-s2147483648") == "BARN-style-s2147483648"
    )
    assert gpr.method_label({"method": "d3dwa", "policy_seed": 3}) == "d3dwa s3"
    assert gpr.method_label({"method": "dwa3", "policy_seed": None}) == "dwa3"
    assert gpr.plan_of({"global_plan": "scan"}) == "scan" and gpr.plan_of({}) == "none"


def test_collisions_count_only_episodes_run_under_both_plans():
    none = [
        _row("BARN-0", "collision", "real"),
        _row("BARN-6", "goal", "real"),
        _row("BARN-12", "collision"),
    ]
    scan = [_row("BARN-0", "goal", "real", "scan"), _row("BARN-6", "goal", "real", "scan")]
    plans = gpr.by_plan([{**r, "seed": 0} for r in none + scan])
    col = gpr.collision_rates(plans)
    assert col["matched_episodes"] == 2 and col["left_out"] == {"none": 1, "scan": 0}
    real_none = col["cells"]["none"]["BARN / real"]
    assert (real_none["k"], real_none["n"], real_none["rate"]) == (1, 2, 0.5)
    lo, hi = real_none["wilson95"]
    assert 0.0 < lo < 0.5 < hi < 1.0
    assert col["cells"]["scan"]["all / all"]["k"] == 0 and "BARN / none" not in col["cells"]["none"]


def test_moonshot_needs_every_cell_at_ninety_percent():
    rows = [
        _row(f"BARN-{6 * i}", "goal", noise, "scan")
        for i in range(10)
        for noise in ("none", "harsh")
    ]
    rows += [
        _row(f"R1-style-s{2**31 + i}", "goal" if i else "timeout", "none", "scan")
        for i in range(10)
    ]
    shot = gpr.moonshot(gpr.by_plan([{**r, "seed": 0} for r in rows]))["scan"]["dwa3"]
    assert shot["cells"]["R-style / none"]["rate"] == pytest.approx(0.9) and shot[
        "lowest"
    ] == pytest.approx(0.9)
    assert (
        shot["every_cell_at_target"] and not shot["every_lower_bound_at_target"]
    )  # 9/10 is no proof
    rows[-1] = _row(f"R1-style-s{2**31 + 9}", "timeout", "none", "scan")
    shot = gpr.moonshot(gpr.by_plan([{**r, "seed": 0} for r in rows]))["scan"]["dwa3"]
    assert not shot["every_cell_at_target"] and shot["lowest"] == pytest.approx(0.8)


def test_the_tool_reads_directories_and_refuses_bad_input(tmp_path, capsys):
    scan = _results(
        tmp_path / "scan",
        [_row("BARN-0", "goal", "harsh", "scan"), _row("BARN-6", "collision", "harsh", "scan")],
    )
    none = _results(
        tmp_path / "none", [_row("BARN-0", "goal", "harsh"), _row("BARN-6", "goal", "harsh")]
    )
    (scan / "logs").mkdir()
    np.savez(scan / "logs" / log_name(("BARN-6", "dwa3", None, 0, "harsh")), plan_status=np.array([0, 1, 1, 0]),
             plan_replans=np.array(3))  # fmt: skip
    assert gpr.main([str(scan), str(none), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["failures"] == {
        "scan / harsh / dwa3": {
            "failed": 1,
            "collisions": 1,
            "logged": 1,
            "ever_off_plan": 1,
            "mean_off_plan_share": 0.5,
        }
    }
    assert report["collisions"]["cells"]["scan"]["BARN / harsh"]["k"] == 1
    assert report["moonshot"]["none"]["dwa3"]["every_cell_at_target"]
    assert (
        gpr.main([str(scan), str(none)]) == 0
        and "| scan | BARN / harsh | 2 | 1 | 500.0" in capsys.readouterr().out
    )
    assert gpr.main([str(scan), str(scan)]) == 2  # one episode given twice
    assert "given twice" in capsys.readouterr().err
    assert gpr.main([str(tmp_path / "missing")]) == 2
    assert "missing: no results.csv rows" in capsys.readouterr().err


def test_compare_rows_come_from_the_all_group_and_refuse_a_record_without_it(tmp_path, capsys):
    def reading(diff, low, high, mean_a, mean_b, verdict):
        return {"difference": diff, "low": low, "high": high, "mean_a": mean_a, "mean_b": mean_b,
                "layouts": 34, "reading": verdict}  # fmt: skip

    readings = {
        "success": reading(0.206, 0.063, 0.349, 1.0, 0.794, "A better"),
        "score": reading(0.156, 0.047, 0.265, 0.74, 0.59, "A better"),
        "score_barn": reading(0.035, None, None, 0.17, 0.13, "inconclusive"),
    }
    record = {
        "groups": [{"group": "barn-easy", "readings": {}}, {"group": "all", "readings": readings}]
    }
    row = gpr.compare_row(record, "dwa3-real")
    assert row.startswith(
        "| dwa3-real | 34 | 100.0 / 79.4 | +20.6 [+6.3, +34.9] | +0.156 [+0.047, +0.265] |"
    )
    assert "+0.035 [-, -]" in row and row.endswith("score_barn inconclusive |")
    path = tmp_path / "x.json"
    path.write_text(json.dumps({"groups": []}))
    assert (
        gpr.main(["--compare", str(path)]) == 2 and "x: no 'all' group" in capsys.readouterr().err
    )
