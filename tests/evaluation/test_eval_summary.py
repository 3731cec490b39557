"""The terminal's page of a run of many worlds (``eval_summary``): conditions and both score
formulas once, every table labelled, no per-world table, no ``100 [100, 100]`` from one run."""

from __future__ import annotations

from d3dwa_bullet.episode_metrics import BARN_SPEED
from d3dwa_bullet.evaluation.eval_summary import TERMINAL_WORLDS, conditions, eval_summary
from d3dwa_bullet.evaluation.page_width import PAGE_WIDTH
from d3dwa_bullet.world.barn import barn_split_ids

CHALLENGE = [f"BARN-{i}" for i in barn_split_ids("challenge")]


def _rows(worlds, seeds=(0,)) -> list[dict]:
    rows = []
    for k, w in enumerate(worlds):
        for s in seeds:
            for m, goal in (("dwa3", k % 4 != 0), ("dwa1", k % 2 == 0)):
                rows.append({"world": w, "method": m, "policy_seed": None, "seed": s, "noise": "none",
                             "outcome": "goal" if goal else "timeout", "time_s": 10.0 + k % 5 + s,
                             "score": 0.5 * goal, "score_barn": 0.2 * goal})  # fmt: skip
    return rows


def test_the_summary_of_barns_challenge_fits_one_screen_and_says_its_conditions():
    assert len(CHALLENGE) == 50 > TERMINAL_WORLDS
    page = eval_summary(_rows(CHALLENGE), ["dwa3", "dwa1"], CHALLENGE, [0], "none")
    lines = page.splitlines()
    assert len(lines) <= 50 and all(len(line) <= PAGE_WIDTH for line in lines)
    label = "BARN challenge split, 50 worlds; noise `none`; recovery layer off"
    assert conditions(CHALLENGE, "none", "none") == label
    assert f"## Over every world ({label})" in page
    assert f"## BARN by difficulty tercile ({label})" in page
    words = " ".join(page.split())  # prose wraps at the page's width
    assert (
        words.count("t_ref = L / v_max") == 1
        and words.count(f"t_opt = L / {BARN_SPEED:g} m/s") == 1
    )
    assert "BARN-17 " not in page and "| BARN-" not in page  # no per-world row
    assert "[100, 100]" not in page and "no cell has an interval" in page
    assert "| DWA III (2,1,1) | 1 evaluation seed | 74 | " in page  # 37 of 50 worlds, no interval


def test_several_runs_a_world_keep_their_intervals():
    worlds = CHALLENGE[:20]
    page = eval_summary(
        _rows(worlds, seeds=(0, 1)), ["dwa3", "dwa1"], worlds, [0, 1], "real", "nav2"
    )
    assert "recovery layer `nav2`" in page and "no cell has an interval" not in page
    assert "| DWA III (2,1,1) | 2 evaluation seeds | 75 [" in page
