"""Results pages keep to 120 characters a line however many worlds (``evaluation.page_width``):
worlds turn to rows and methods split into tables side by side no wider than the page; every
(world, method) value is still on the page, with its training-world mark; a page of few worlds
keeps its layout; beyond MANY_WORLDS only the aggregates stay. Results directories made with the
project's writer and read back with its reader; no episode runs."""

from __future__ import annotations

import json
from collections import defaultdict

import numpy as np
import pytest
from scipy.stats import trim_mean

from d3dwa_bullet.evaluation.page_width import (
    MANY_WORLDS,
    PAGE_WIDTH,
    WorldRow,
    fit_prose,
    split_columns,
    world_table,
)
from d3dwa_bullet.evaluation.report import eval_markdown, seeds_markdown, write_report
from d3dwa_bullet.evaluation.results import read_results
from d3dwa_bullet.evaluation.seed_tables import improvement_table
from d3dwa_bullet.evaluation.sweep import sweep_markdown
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.evaluation.training_worlds import MARK
from d3dwa_bullet.learning.agents.barn_record import BarnTraining
from d3dwa_bullet.method_specs import method_label
from d3dwa_bullet.world.barn_difficulty import barn_tercile
from tests.support.results_logs import write_results

FIXED = ("dwa1", "dwa2", "dwa3", "random", "random@10", "random-weights@10")
LEARNED = ("d3dwa", "d3dwa-dr-barn")
METHODS = FIXED + LEARNED  # 8 methods, the longest labels among them
SEEDS = (0, 1, 2)
TRAINED = {"d3dwa-dr-barn": BarnTraining("train", (1, 2, 3))}  # BARN-1..3: train worlds


# Every run of a (world, method) alike: its intervals are points, so no bootstrap resamples
# and the test stays fast; the widest cells ("100 [100, 100]") are as wide as real ones.
def _goal(i: int, j: int, run: int) -> bool:
    return (i + 2 * j) % 4 != 0


def _time(i: int, j: int, run: int) -> float:
    return round(20.0 + i + j / 8, 3)


def _episodes(worlds):
    """One method j on world i: a fixed method's runs are its evaluation seeds (noise `real`),
    a learned method's its training seeds (evaluation seed 0); it reaches the goal unless
    (i + 2 j) % 4 == 0, in _time(i, j, r) s, scoring 10 / time."""
    rows = []
    for i, w in enumerate(worlds):
        for j, m in enumerate(METHODS):
            for r in SEEDS:
                goal = _goal(i, j, r)
                t = _time(i, j, r)
                policy_seed, seed = (r, 0) if m in LEARNED else ("", r)
                rows.append(dict(world=w, method=m, policy_seed=policy_seed, seed=seed,
                                 noise="real", outcome="goal" if goal else "timeout", time_s=t,
                                 score=round(10 / t, 6) if goal else 0.0,
                                 score_barn=round(2 / t, 6) if goal else 0.0))  # fmt: skip
    return rows


def _results(path, worlds):
    """A results directory by the project's writer, and its rows by its reader."""
    write_results(path, ((r, {}) for r in _episodes(worlds)), sweep=False)
    jobs = [(r["world"], r["method"], r["policy_seed"] if r["policy_seed"] != "" else None,
             r["seed"], r["noise"]) for r in _episodes(worlds)]  # fmt: skip
    meta = {"format": 4, "version": "test", "config": {},
            "settings": {"kind": "eval", "methods": list(METHODS), "worlds": list(worlds),
                         "seeds": list(SEEDS), "noise": "real",
                         "barn_training": {m: t.to_dict() for m, t in TRAINED.items()}},
            "jobs": [list(j) for j in jobs]}  # fmt: skip
    (path / "meta.json").write_text(json.dumps(meta))
    return read_results(path)


def _expected(worlds):
    """Per (world, method), computed here from the design, not by the package: success %,
    IQM of the runs' times, mean score, the paper's pooled mean time, the per-seed cells."""
    out = {}
    for i, w in enumerate(worlds):
        for j, m in enumerate(METHODS):
            goals = [_goal(i, j, r) for r in SEEDS]
            times = [_time(i, j, r) for r in SEEDS if _goal(i, j, r)]
            scores = [10 / _time(i, j, r) if _goal(i, j, r) else 0.0 for r in SEEDS]
            seeds = {r: (f"1/1, {_time(i, j, r):.1f} s" if _goal(i, j, r) else "0/1 (0 C, 1 T)")
                     for r in SEEDS}  # fmt: skip
            if m in FIXED:
                seeds = {None: f"3/3, {np.mean(times):.1f} s" if times else "0/3 (0 C, 3 T)"}
            out[(w, m)] = dict(
                success=f"{100 * np.mean(goals):.0f} [",
                time=f"{trim_mean(times, 0.25):.1f} [" if times else "--",
                score=f"{np.mean(scores):.2f} [",
                paper=f"{np.mean(times):.2f}" if times else "T",
                seeds=seeds,
            )
    return out


def _sections(page: str) -> dict[str, str]:
    """A page's text under each heading."""
    parts, title = defaultdict(str), ""
    for line in page.splitlines():
        if line.startswith("#"):
            title = line.lstrip("#").strip()
        else:
            parts[title] += line + "\n"
    return parts


def _world_cells(text: str) -> dict[tuple[str, str], list[str]]:
    """(world, column title) -> cells of every `World` table in text; a column block's other
    sub-columns (TL, PD) follow its first under its title."""
    cells: dict[tuple[str, str], list[str]] = defaultdict(list)
    for block in text.split("\n\n"):
        lines = [line for line in block.splitlines() if line.startswith("|")]
        if not lines or not lines[0].startswith("| World |"):
            continue
        header = [c.strip() for c in lines[0].split("|")[1:-1]]
        owner, titles = "", []
        for h in header[1:]:
            if h not in ("TL", "PD"):
                owner = h.removesuffix(" Time")
            titles.append(owner)
        for line in lines[2:]:
            row = [c.strip() for c in line.split("|")[1:-1]]
            for title, cell in zip(titles, row[1:], strict=True):
                cells[(row[0], title)].append(cell)
    return cells


def _assert_fits(page: str) -> None:
    wide = [line for line in page.splitlines() if len(line) > PAGE_WIDTH]
    assert not wide, f"{len(wide)} lines over {PAGE_WIDTH}: {wide[0][:80]}..."


WORLDS50 = [f"BARN-{i}" for i in range(50)]


@pytest.fixture(scope="module")
def fifty(tmp_path_factory):
    return _results(tmp_path_factory.mktemp("fifty"), WORLDS50)


def test_fifty_worlds_eight_methods_fit_and_keep_every_value(fifty):
    page = eval_markdown(fifty, METHODS, WORLDS50, list(SEEDS), "real", barn_training=TRAINED)
    _assert_fits(page)
    sections, expected = _sections(page), _expected(WORLDS50)
    success = _world_cells(
        sections["Success rate [%], 95 % interval over runs (none where a cell has one run)"]
    )
    timing = _world_cells(sections["Time to goal, IQM over runs [s], 95 % interval"])
    score = _world_cells(sections["Score (kachaka-v2), mean over runs, 95 % interval"])
    paper = _world_cells(sections["Paper layout, pooled over every run"])
    for (w, m), want in expected.items():
        assert [c.startswith(want["success"]) for c in success[(w, m)]] == [True], (
            w,
            m,
            success[(w, m)],
        )
        assert [c.startswith(want["time"]) for c in timing[(w, m)]] == [True], (w, m)
        assert [c.startswith(want["score"]) for c in score[(w, m)]] == [True], (w, m)
        time_cell, _tl, _pd = paper[(w, m)]
        assert time_cell.strip("*").startswith(want["paper"]), (w, m, time_cell)
        marked = m in TRAINED and w in TRAINED[m].names
        for cells in (success[(w, m)], timing[(w, m)], score[(w, m)], [time_cell]):
            assert cells[0].endswith(MARK) == marked, (w, m, cells)
    # each method's label and runs are named once, and its "all" row follows the worlds
    assert all(f"| {m} | {method_label(m)} |" in page for m in METHODS)
    assert len(success[("all", "dwa1")]) == 1 and len(score[("all", "d3dwa")]) == 1


def test_fifty_worlds_per_seed_page_fits_and_keeps_every_seed_cell(fifty):
    page = seeds_markdown(fifty, METHODS, WORLDS50, TRAINED)
    _assert_fits(page)
    cells = _world_cells(page)
    for (w, m), want in _expected(WORLDS50).items():
        for seed, text in want["seeds"].items():
            title = m if seed is None else f"{m} seed {seed}"
            marked = MARK if m in TRAINED and w in TRAINED[m].names else ""
            assert cells[(w, title)] == [text + (f" {MARK}" if marked else "")], (w, title)
    assert cells[("success", "dwa3")] and cells[("BARN", "d3dwa seed 2")]


def test_the_report_page_of_fifty_worlds_fits(tmp_path):
    worlds = [f"layout-{i:03d}" for i in range(50)]  # no world file: no figure drawn
    _results(tmp_path / "out", worlds)
    report = write_report(tmp_path / "out", policies_dir=tmp_path / "no-policies")
    page = report.path.read_text()
    _assert_fits(page)
    success = _world_cells(
        _sections(page)["Success rate [%], 95 % interval over runs (none where a cell has one run)"]
    )
    for (w, m), want in _expected(worlds).items():
        assert success[(w, m)][0].startswith(want["success"])


def test_more_than_many_worlds_keep_the_aggregates_and_point_to_results_csv(tmp_path):
    worlds = [f"BARN-{i}" for i in range(MANY_WORLDS + 10)]
    rows = _results(tmp_path / "many", worlds)
    page = eval_markdown(rows, METHODS, worlds, list(SEEDS), "real", barn_training=TRAINED)
    seeds = seeds_markdown(rows, METHODS, worlds, TRAINED)
    for text in (page, seeds):
        _assert_fits(text)
        assert f"Per-world cells of these {len(worlds)} worlds: results.csv" in text
        assert "| BARN-5 |" not in text and "| World |" not in text
    all_success = [line for line in page.splitlines() if line.startswith("| DWA I (1,1,2) |")]
    goals = [_goal(i, 0, r) for i in range(len(worlds)) for r in SEEDS]
    assert f"| {100 * np.mean(goals):.0f} [" in all_success[0]  # the "all" cell, success
    assert "| barn-challenge |" in page and "| barn-hard |" in page  # the BARN groups stay


def test_a_page_of_few_worlds_keeps_its_layout(tmp_path):
    worlds = ["R1", "R2"]
    rows = [r for r in _results(tmp_path / "few", worlds) if r["method"] in ("dwa3", "d3dwa")]
    page = eval_markdown(rows, ["dwa3", "d3dwa"], worlds, list(SEEDS), "real")
    _assert_fits(page)
    lines = page.splitlines()
    assert lines.count("| Method | runs | R1 | R2 | all |") == 2
    assert lines.count("|---|---|---:|---:|---:|") == 2
    assert "| Method | R1 | R2 | all |" in lines
    assert "| Method | R1 Time | R1 TL | R1 PD | R2 Time | R2 TL | R2 PD |" in lines
    assert "| World |" not in page and "| name |" not in page
    per_seed = seeds_markdown(rows, ["dwa3", "d3dwa"], worlds).splitlines()
    assert "| Method | training seed | R1 | R2 | success | score | BARN |" in per_seed
    assert sum(line.startswith("| D3DWA | ") for line in per_seed) == 3  # a row per seed


def test_sweep_page_of_a_whole_split_fits(fifty):
    settings = SweepSettings(methods=METHODS, worlds=tuple(WORLDS50), styles=(), layouts=0,
                             seeds=3, axes=(), profiles=("none", "paper", "real", "harsh"))  # fmt: skip
    rows = [r | {"layout": "barn-easy", "axis": "profile", "level": None} for r in fifty]
    page = sweep_markdown(rows, settings, TRAINED)
    _assert_fits(page)
    easy = [w for w in WORLDS50 if barn_tercile(int(w.removeprefix("BARN-"))) == "easy"]
    assert len(easy) > 8  # more than a title names: counted, not listed
    said = f"*barn-easy* = BARN easy tercile: {len(easy)} worlds, {easy[0]} to {easy[-1]}"
    assert said in " ".join(page.split())


def test_split_columns_keeps_keys_and_blocks_and_every_cell():
    header = ["Method", *(f"column {k}" for k in range(12))]
    rows = [[f"m{i}", *(f"{i}-{k} [0.00, 1.00]" for k in range(12))] for i in range(3)]
    text = split_columns(header, ["---"] + ["---:"] * 12, rows, keys=1, block=2)
    _assert_fits(text)
    tables = text.split("\n\n")
    assert len(tables) > 1 and all(t.startswith("| Method | column ") for t in tables)
    assert all(f"| {i}-{k} [0.00, 1.00] |" in text for i in range(3) for k in range(12))
    widths = [len(t.splitlines()[0].split("|")) - 3 for t in tables]  # value columns a table
    assert all(w % 2 == 0 for w in widths[:-1]) and sum(widths) == 12


def test_world_table_fits_as_it_was_when_it_can():
    rows = [WorldRow(("DWA",), [("1",), ("2",)], ("3",))]
    assert world_table(("Method",), ("---",), ["A", "B"], rows, tail=("all",)) == (
        "| Method | A | B | all |\n|---|---:|---:|---:|\n| DWA | 1 | 2 | 3 |\n"
    )


def test_fit_prose_splits_long_lines_only_and_keeps_quotes():
    words = " ".join(f"word{i}" for i in range(60))
    text = f"# {words}\n> {words}\nshort\n| {words} |\n{words}"
    out = fit_prose(text).splitlines()
    assert out[0] == f"# {words}" and f"| {words} |" in out and "short" in out
    prose = [line for line in out[1:] if not line.startswith("|") and line != "short"]
    assert all(len(line) <= PAGE_WIDTH for line in prose)
    assert " ".join(prose).replace("> ", "").split() == (words + " " + words).split()
    quote = out[1 : out.index("short")]
    assert len(quote) > 1 and all(line.startswith("> ") for line in quote)  # still one quote


def test_improvement_table_of_the_longest_labels_fits_and_keeps_every_cell():
    record = dict(group="barn-middle (real) † (12 of 30 trained on)", tasks=30, runs_a=3,
                  runs_b=3, p=0.61, low=0.52, high=0.7, paired_units=90, paired_wins=40,
                  paired_losses=21, paired_p=0.0123)  # fmt: skip
    table = improvement_table([record], "random@10", "random-weights@10")
    _assert_fits(table)
    for text in (record["group"], "| 0.61 |", "| [0.52, 0.70] |", "| 40 / 21 |", "| 0.0123 |"):
        assert text in table
    # the two floors' labels are too long for a column of their own: A and B, as compare's
    # text names them; a shorter pair keeps its labels, split into tables that fit
    assert "| P(A > B) |" in table
    table = improvement_table([record], "d3dwa-history-dr", "dwa3")
    _assert_fits(table)
    assert "P(D3DWA" in table and "| P(A > B) |" not in table
    assert table.count("| tasks |") == len(table.split("\n\n")) > 1  # split, key kept
