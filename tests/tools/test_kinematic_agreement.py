"""The agreement study's reader: a cell's text and verdict from d3dwa compare's record, and where
two runs' paths part."""

from __future__ import annotations

import numpy as np
import pytest

from tools.experiments.agreement_paths import PART, parting
from tools.experiments.kinematic_agreement import cell_text, main, table_row, verdict


def record(reading: dict, profile: str = "real") -> dict:
    return {
        "groups": [
            {"group": "all layouts, noise none", "readings": {}},
            {
                "group": f"all layouts, noise {profile}",
                "readings": {"success": reading, "score": reading},
            },
        ]
    }


def inconclusive(needed: int | None = 95, to_equivalence: int | None = 200) -> dict:
    return {"metric": "success", "reading": "inconclusive", "why": None, "difference": 1 / 12, "low": -0.1,
            "high": 0.267, "layouts": 12, "margin": 0.03, "needed": needed, "needed_equivalence": to_equivalence,
            "equivalent": False}  # fmt: skip


def equivalent(reading: str = "equivalent") -> dict:
    return {"metric": "score", "reading": reading, "why": None, "difference": 0.004, "low": 0.001, "high": 0.008,
            "layouts": 40, "margin": 0.03, "needed": None, "equivalent": True}  # fmt: skip


def test_a_cell_names_its_reading_difference_interval_and_layouts():
    success = cell_text(record(inconclusive()), "real", "success")
    assert success.startswith("inconclusive") and "+8.33 pt [-10, +26.7], n=12" in success
    assert "+0.0833 [-0.1, +0.267], n=12" in cell_text(record(inconclusive()), "real", "score")


def test_a_cell_says_what_is_missing():
    assert cell_text(None, "real", "success") == "not run"
    assert cell_text(record({}), "harsh", "success") == "no pairs"
    assert cell_text(record({}), "none", "success") == "no pairs"


def test_the_backend_may_answer_only_where_both_metrics_are_equivalent():
    assert verdict(equivalent(), equivalent()) == "yes"
    # a difference inside the margin is still equivalent within it (TOST rejected)
    assert verdict(equivalent("B better"), equivalent()) == "yes"
    assert verdict(equivalent(), inconclusive(40, 60)) == "no: eq. needs ~60"
    assert verdict(inconclusive(95, 120), inconclusive(151, 80)) == "no: eq. needs ~120"
    assert verdict(inconclusive(44, None), equivalent()) == "no: eq. unreachable"
    outside = inconclusive() | {"reading": "A better"}
    assert verdict(outside, equivalent()) == "no: differs"
    assert verdict(None, equivalent()) == "not run"


def test_a_table_row_carries_the_cell_n_readings_and_verdict():
    row = table_row("r-style", "nav2", "real", "d3dwa", record(equivalent()))
    assert (
        row
        == "| r-style | nav2 | real | d3dwa | 40 | +0.4 [+0.1, +0.8] | +0.004 [+0.001, +0.008] | yes |"
    )
    assert table_row("barn-style", "none", "none", "dwa3", None).endswith("| - | - | not run |")


def test_with_one_profile_the_cell_reads_compares_pooled_group():
    one = {"groups": [{"group": "given, noise none", "readings": {}},
                      {"group": "all", "readings": {"success": equivalent(), "score": equivalent()}}]}  # fmt: skip
    assert table_row("r-style", "none", "none", "dwa3", one).endswith("| yes |")
    # with several profiles "all" pools them: never read as one profile's
    assert cell_text(record(equivalent(), "real") | {"groups": record(equivalent())["groups"] + one["groups"][1:]},
                     "none", "score") == "no pairs"  # fmt: skip


def log(xs: list[float], actions: list[int]) -> dict:
    """A log of len(actions) steps at 10 Hz moving along x through xs (len(actions) + 1 poses)."""
    return {"t": np.arange(len(actions)) * 0.1, "true_x": np.asarray(xs), "true_y": np.zeros(len(xs)),
            "action": np.asarray(actions)}  # fmt: skip


def test_parting_finds_the_first_step_apart_and_the_first_different_action():
    a = log([0.0, 0.1, 0.2, 0.3, 0.4], [1, 1, 1, 1])
    b = log([0.0, 0.1, 0.205, 0.3 + PART + 0.01, 0.5], [1, 1, 2, 2])
    p = parting(a, b)
    assert p["part_s"] == pytest.approx(0.3)
    assert p["action_s"] == pytest.approx(0.2) and p["action_gap_mm"] == pytest.approx(5.0)


def test_runs_that_never_part_have_no_parting_time():
    a = log([0.0, 0.1, 0.2], [3, 3])
    p = parting(a, log([0.0, 0.1, 0.2, 0.3], [3, 3, 3]))  # the other ran one step longer
    assert p == {"part_s": None, "action_s": None, "action_gap_mm": None}


def test_a_missing_runs_directory_is_one_line_and_status_2(tmp_path, capsys):
    assert main([str(tmp_path / "absent")]) == 2
    err = capsys.readouterr().err.strip()
    assert "absent: not a directory" in err and "\n" not in err
