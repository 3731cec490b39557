"""The agreement study's reader: a cell's text from d3dwa compare's record."""

from __future__ import annotations

from tools.experiments.kinematic_agreement import cell_text


def record(reading: dict) -> dict:
    return {
        "groups": [
            {"group": "all layouts (real)", "readings": {"success": reading, "score": reading}}
        ]
    }


def test_a_cell_names_its_reading_difference_interval_and_layouts():
    r = {"metric": "success", "reading": "inconclusive", "why": None, "difference": 1 / 12, "low": -0.1, "high": 0.267, "layouts": 12,
         "margin": 0.03, "needed": 95}  # fmt: skip
    success = cell_text(record(r), "real", "success")
    assert success.startswith("inconclusive") and "+8.33 pt [-10, +26.7], n=12" in success
    assert "+0.0833 [-0.1, +0.267], n=12" in cell_text(record(r), "real", "score")


def test_a_cell_says_what_is_missing():
    assert cell_text(None, "real", "success") == "not run"
    assert cell_text(record({}), "harsh", "success") == "no pairs"
