"""Holm over a family of readings: adjusted p-values, re-read by the one rule, never bolder."""

from __future__ import annotations

import pytest
from statsmodels.stats.multitest import multipletests

from d3dwa_bullet.evaluation.multiplicity import holm


def _record(p_a, p_b, tost, reading):
    return {"p_a_better": p_a, "p_b_better": p_b, "tost_p": tost, "reading": reading, "metric": "score",
            "margin": 0.03, "needed": 10}  # fmt: skip


def test_holm_adjusts_the_difference_and_tost_and_rereads():
    records = [
        _record(0.001, 0.999, 0.9, "A better"),  # two-sided 0.002: survives Holm over 3
        _record(0.015, 0.985, 0.9, "A better"),  # two-sided 0.03: does not
        _record(0.6, 0.4, 0.01, "equivalent"),  # TOST 0.01 x 2 (second step) = 0.02 < 0.05
        {"reading": None, "why": "no score"},  # no p-values: out of the family
    ]
    out = holm(records)
    expected = multipletests([0.002, 0.03, 0.8], method="holm")[1]
    assert [r["p_difference"] for r in out[:3]] == pytest.approx(list(expected))
    assert [r["reading"] for r in out[:3]] == ["A better", "inconclusive", "equivalent"]
    assert out[1]["reading_unadjusted"] == "A better" and out[1]["needed"] is None
    assert "before Holm" in out[1]["why"]
    assert {r["adjusted"] for r in out[:3]} == {"Holm over 3"} and out[3]["adjusted"] is None
    assert out[3]["reading"] is None


def test_an_adjusted_reading_is_never_bolder():
    records = [_record(p, 1 - p, t, r) for p, t, r in
               [(0.01, 0.2, "A better"), (0.3, 0.04, "equivalent"), (0.2, 0.3, "inconclusive")]]  # fmt: skip
    for before, after in zip(records, holm(records), strict=True):
        if before["reading"] == "inconclusive":
            assert after["reading"] == "inconclusive"
        assert after["reading"] in (before["reading"], "inconclusive")
        assert after["tost_p_adjusted"] >= before["tost_p"]
