"""A sweep's unseen layouts by generator style: the strata its page and compare add."""

from __future__ import annotations

import pytest

from d3dwa_bullet.evaluation.style_tables import style_of, style_section, styles_present
from d3dwa_bullet.world.generator import generated_style


@pytest.mark.parametrize(
    ("name", "style"),
    [("R2-style-s17", "R2-style"), ("R1-style-s2147483648", "R1-style"), ("R2", None),
     ("R9-style-s3", None), ("R2-style-s", None), ("R2-style-sx", None), ("BARN-17", None)],
)  # fmt: skip
def test_the_style_of_a_generated_name(name, style):
    assert generated_style(name) == style


def _row(world, outcome, layout="generated", method="dwa3", seed=0):
    return {"world": world, "layout": layout, "method": method, "seed": seed,
            "policy_seed": None, "noise": "none", "outcome": outcome,
            "time_s": 20.0 if outcome == "goal" else 60.0,
            "score": 0.5 if outcome == "goal" else 0.0,
            "score_barn": 0.1 if outcome == "goal" else 0.0}  # fmt: skip


def test_only_a_sweeps_unseen_layouts_have_a_style():
    assert style_of(_row("R2-style-s17", "goal")) == "R2-style"
    assert style_of(_row("R2-style-s17", "goal", layout="given")) is None  # named in --worlds
    assert style_of({"world": "R2-style-s17"}) is None  # an eval row: no layout column
    rows = [_row("R3-style-s1", "goal"), _row("R1", "goal", "shipped"), _row("R1-style-s1", "goal")]
    assert styles_present(rows) == ["R1-style", "R3-style"]


def test_the_section_has_a_row_per_style_and_leaves_other_worlds_out():
    rows = [_row("R1-style-s1", "goal"), _row("R1-style-s2", "goal"),
            _row("R2-style-s1", "timeout"), _row("R2-style-s2", "goal"),
            _row("R1", "timeout", "shipped")]  # fmt: skip
    page = style_section(rows, ["dwa3"], ["none"], lambda r: r["noise"])
    success = page.split("The score")[0]
    cells = {ln.split("|")[2].strip(): ln.split("|")[3].strip()
             for ln in success.splitlines() if ln.startswith("| DWA")}  # fmt: skip
    assert list(cells) == ["R1-style", "R2-style", "all layouts"]
    # one run a world: the value alone, no interval
    assert cells == {"R1-style": "100", "R2-style": "50", "all layouts": "75"}  # no shipped R1
    score = page.split("The score")[1]
    assert "| R1-style | 0.50 |" in score and "| R2-style | 0.25 |" in score


def test_one_style_adds_nothing():
    rows = [_row("R1-style-s1", "goal"), _row("R1-style-s2", "timeout")]
    assert style_section(rows, ["dwa3"], ["none"], lambda r: r["noise"]) == ""
