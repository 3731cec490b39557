"""Pages flag a learned method's results on the BARN worlds its policy trained on
(``evaluation.training_worlds``): one line per such method, a mark on its cells on those worlds,
and a count on its BARN split and tercile rows; nothing for a method that trained on none."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.policy_runs import PolicyRun
from d3dwa_bullet.evaluation.report import eval_markdown, seeds_markdown
from d3dwa_bullet.evaluation.sweep import sweep_markdown
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.evaluation.training_worlds import (
    MARK,
    group_count,
    group_flag,
    read_barn_training,
    runs_barn_training,
    trained_counts,
    training_lines,
)
from d3dwa_bullet.learning.agents.barn_record import BarnTraining, barn_record
from d3dwa_bullet.world.barn_difficulty import barn_tercile

TRAINED = {"d3dwa": BarnTraining("train", (1, 61))}
WORLDS = ["BARN-1", "BARN-0"]  # a training world of d3dwa, then a challenge world


def _row(method, world, policy_seed, seed, goal):
    return dict(method=method, world=world, policy_seed=policy_seed, seed=seed, noise="none",
                outcome="goal" if goal else "timeout", time_s=30.0, tl_m=10.0, pd_rad=1.0,
                score=0.5 * goal, score_barn=0.2 * goal)  # fmt: skip


def _rows(worlds=WORLDS):
    return [_row("d3dwa", w, k, 0, k == 0) for w in worlds for k in (0, 1)] + [
        _row("dwa3", w, None, 0, True) for w in worlds
    ]


def _cells(page: str, label: str) -> list[list[str]]:
    """The cells of every table line of ``label`` (a method's label) on a page."""
    return [
        [c.strip() for c in line.split("|")[2:-1]]
        for line in page.splitlines()
        if line.startswith(f"| {label} |")
    ]


def test_the_page_names_the_training_worlds_and_marks_only_their_cells():
    page = eval_markdown(_rows(), ["d3dwa", "dwa3"], WORLDS, [0], "none", barn_training=TRAINED)
    assert "`d3dwa` trained on 2 of BARN's 250 train worlds" in page
    # prose lines are split to the page's width (page_width.fit_prose): read it as words
    assert "1 of this page's worlds is one of them (BARN-1)" in " ".join(page.split())
    lines = _cells(page, "D3DWA")
    per_world = [c for c in lines if len(c) == 4] + [next(c for c in lines if len(c) == 3)]
    assert len(per_world) == 3  # success, time (after "runs"), score: the worlds, then "all"
    for cells in per_world:
        trained, held_out = cells[-3], cells[-2]
        assert trained.endswith(MARK) and MARK not in held_out, cells
    paper = next(c for c in _cells(page, "D3DWA") if len(c) == 6)  # Time, TL, PD per world
    assert paper[0].endswith(MARK) and MARK not in "".join(paper[1:])
    assert all(MARK not in "".join(c) for c in _cells(page, "DWA III (2,1,1)"))


def test_the_split_and_tercile_rows_say_how_many_of_their_worlds_are_training_worlds():
    page = eval_markdown(_rows(), ["d3dwa", "dwa3"], WORLDS, [0], "none", barn_training=TRAINED)
    groups = [c[0] for c in _cells(page, "D3DWA") if c and c[0].startswith(("barn", "all lay"))]
    assert f"barn-train {MARK} (1 of 1 trained on)" in groups
    assert "barn-challenge" in groups  # the challenge row: no mark
    assert f"barn-{barn_tercile(1)} {MARK} (1 of 1 trained on)" in groups
    assert f"all layouts {MARK} (1 of 2 trained on)" in groups
    fixed = [c[0] for c in _cells(page, "DWA III (2,1,1)") if c and c[0].startswith("barn")]
    assert fixed and all(MARK not in g for g in fixed)


def test_a_group_flag_counts_the_method_s_training_worlds_and_tags_it_when_asked():
    trained = {"a": {"BARN-1", "BARN-2"}, "b": {"BARN-3"}}
    group = ["BARN-1", "BARN-2", "BARN-0"]
    assert trained_counts(trained, group) == {"a": 2}  # b trained on none of them
    assert group_flag(trained)("a", group) == f" {MARK} (2 of 3 trained on)"
    assert group_flag(trained)("b", group) == "" and group_flag(None)("a", group) == ""
    tagged = group_flag(trained, {"a": "A", "b": "B"})
    assert tagged("a", group) == f" {MARK} (A: 2 of 3 trained on)"
    assert tagged("b", ["BARN-3"]) == f" {MARK} (B: 1 of 1 trained on)"
    assert group_count(trained)("a", group) == "2 of 3" and group_count(trained)("b", group) == ""


def test_a_challenge_only_page_has_the_line_and_no_mark():
    rows = _rows(["BARN-0", "BARN-6"])
    page = eval_markdown(rows, ["d3dwa", "dwa3"], ["BARN-0", "BARN-6"], [0], "none",
                         barn_training=TRAINED)  # fmt: skip
    assert "`d3dwa` trained on 2 of BARN's 250 train worlds" in page
    words = " ".join(page.split())  # prose lines split to the page's width
    assert "none of this page's worlds is one of them" in words and MARK not in page


def test_a_policy_without_barn_training_has_neither_line_nor_mark():
    page = eval_markdown(_rows(), ["d3dwa", "dwa3"], WORLDS, [0], "none")
    assert MARK not in page and "trained on" not in page
    assert MARK not in seeds_markdown(_rows(), ["d3dwa", "dwa3"], WORLDS)


def test_the_seed_page_marks_every_seed_of_the_method_on_its_training_world():
    page = seeds_markdown(_rows(), ["d3dwa", "dwa3"], WORLDS, TRAINED)
    assert "`d3dwa` trained on 2 of BARN's 250 train worlds" in page
    seeds = _cells(page, "D3DWA")
    assert len(seeds) == 2 and all(c[1].endswith(MARK) and MARK not in c[2] for c in seeds)
    assert MARK not in "".join(_cells(page, "DWA III (2,1,1)")[0])


def test_the_sweep_page_flags_the_tercile_rows_of_the_method_that_trained_there():
    settings = SweepSettings(methods=("d3dwa", "dwa3"), worlds=("BARN-1",), styles=(),
                             layouts=0, seeds=1, axes=(), profiles=("none",))  # fmt: skip
    rows = [r | {"layout": f"barn-{barn_tercile(1)}", "axis": "profile", "level": None}
            for r in _rows(["BARN-1"])]  # fmt: skip
    page = sweep_markdown(rows, settings, TRAINED)
    assert "`d3dwa` trained on 2 of BARN's 250 train worlds" in page
    flagged = f"barn-{barn_tercile(1)} {MARK} (1 of 1 trained on)"
    assert any(flagged in c for c in _cells(page, "D3DWA"))
    assert all(MARK not in "".join(c) for c in _cells(page, "DWA III (2,1,1)"))
    assert MARK not in sweep_markdown(rows, settings)


def test_more_training_worlds_on_a_page_than_shown_are_counted():
    many = [f"BARN-{i}" for i in range(1, 10)]
    line = training_lines({"d3dwa": BarnTraining("train", tuple(range(1, 6)) + (7, 8, 9))}, many)
    assert (
        "8 of this page's worlds are among them (BARN-1, BARN-2, BARN-3, BARN-4, BARN-5, ...)"
        in line
    )


def _policy(folder, metadata):
    folder.mkdir(parents=True)
    (folder / "meta.json").write_text(json.dumps({"metadata": metadata}))
    return str(folder)


def test_the_runs_of_a_method_give_the_union_of_their_seeds_worlds(tmp_path):
    runs = [
        PolicyRun("d3dwa", 0, _policy(tmp_path / "seed-0", barn_record("train", (1, 7)))),
        PolicyRun("d3dwa", 1, _policy(tmp_path / "seed-1", barn_record("train", (2,)))),
        PolicyRun("d3dwa-weights", 0, _policy(tmp_path / "w", {})),
        PolicyRun("dwa3"),
    ]
    assert runs_barn_training(runs) == {"d3dwa": BarnTraining("train", (1, 2, 7))}


def test_a_results_directory_gives_back_what_the_evaluation_kept(tmp_path):
    meta = {"settings": {"barn_training": {"d3dwa": {"split": "train", "ids": [1, 61]}}}}
    assert read_barn_training(tmp_path, meta) == TRAINED
    assert read_barn_training(tmp_path, {"settings": {}}) == {}


@pytest.mark.parametrize(
    "entry", [[1], {"d3dwa": {"split": "challenge", "ids": [0]}}, {"d3dwa": {"split": "train"}}]
)
def test_a_hand_edited_record_in_meta_is_refused_in_one_line(tmp_path, entry):
    with pytest.raises(ResultsError) as err:
        read_barn_training(tmp_path, {"settings": {"barn_training": entry}})
    text = str(err.value)
    assert "\n" not in text and f"{tmp_path / 'meta.json'}: settings.barn_training" in text
