"""The episode score in the tables (docs/design/score.md#score): over runs, with 95 % intervals.

Per run (a learned method's training seed, a fixed method's evaluation seed: see
:mod:`~d3dwa_bullet.evaluation.seed_tables`), the mean score of its episodes (a failure
scores 0); over runs, the same stratified bootstrap as success
(:mod:`~d3dwa_bullet.evaluation.seed_stats`): the mean over tasks with its interval, and the
interquartile mean (IQM) of every run's score pooled. The robot form (``SCORE_FORM``) leads;
BARN's official form is printed beside it for published numbers. Rows from before the score
have none: a table then prints :data:`~d3dwa_bullet.evaluation.scores.UNSCORED_NOTE`.

Pure functions of results rows: no simulator, no torch.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Collection, Sequence
from functools import partial

from d3dwa_bullet.episode_metrics import SCORE_FORM
from d3dwa_bullet.evaluation.page_width import WorldRow, world_table
from d3dwa_bullet.evaluation.scores import UNSCORED_NOTE, is_scored
from d3dwa_bullet.evaluation.seed_stats import Interval, iqm_interval, mean_interval
from d3dwa_bullet.evaluation.seed_tables import Row, column_scores, condition_table, one_run_each
from d3dwa_bullet.method_specs import method_label

ROBOT = "score"
BARN = "score_barn"


def _fmt(i: Interval, digits: int) -> str:
    return f"{i.value:.{digits}f} [{i.low:.{digits}f}, {i.high:.{digits}f}]"


def score_cell(per_world: list[list[float]], stat=mean_interval, digits: int = 2) -> str:
    """A table cell: ``stat`` (mean_interval or iqm_interval) of per-world lists of per-run
    scores, as "value [low, high]"; the value alone with one run a world (no interval)."""
    i = stat(per_world)
    return f"{i.value:.{digits}f}" if one_run_each(per_world) else _fmt(i, digits)


def _per_world(rows: Sequence[Row], column: str) -> list[list[float]]:
    worlds: dict[str, list[Row]] = defaultdict(list)
    for r in rows:
        worlds[r["world"]].append(r)
    return [column_scores(rs, column) for rs in worlds.values()]


def score_tables(
    rows: Sequence[Row],
    methods: Sequence[str],
    worlds: Sequence[str],
    mark: Callable[[str, str], str] | None = None,
) -> str:
    """Markdown: the robot-form score per (method, world), mean over runs [95 % interval]
    with an "all" column (mean over worlds), then per method over every world: the mean and
    IQM of the robot form and the mean of BARN's (at most 115 characters wide with the longest
    method label). Rows from before the score: the note instead. mark: the text after a
    (method, world) cell (a training world's mark, ``training_worlds.cell_mark``). Worlds too
    many for the page's width are rows, methods columns (``page_width.world_table``)."""
    head = f"### Score ({SCORE_FORM}), mean over runs, 95 % interval\n\n"
    if not is_scored(rows):
        return f"{head}{UNSCORED_NOTE}\n"
    per_world: list[WorldRow] = []
    summary = [
        "| Method | mean [95 %] | IQM [95 %] | BARN mean [95 %] |",
        "|---|---:|---:|---:|",
    ]
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        if not mine:
            continue
        cells = []
        for w in worlds:
            rs = [r for r in mine if r["world"] == w]
            flag = mark(m, w) if mark else ""
            cells.append((score_cell([column_scores(rs, ROBOT)]) + flag if rs else "",))
        robot, barn = _per_world(mine, ROBOT), _per_world(mine, BARN)
        per_world.append(WorldRow((method_label(m),), cells, (score_cell(robot),), m))
        summary.append(
            f"| {method_label(m)} | {score_cell(robot)} | {score_cell(robot, iqm_interval)} | "
            f"{score_cell(barn, digits=3)} |"
        )
    return (
        head
        + world_table(("Method",), ("---",), worlds, per_world, tail=("all",))
        + f"\n### Score over every world: {SCORE_FORM} and BARN's official form\n\n"
        + "\n".join(summary)
        + "\n"
    )


def score_condition_tables(
    rows: Sequence[Row],
    methods: Sequence[str],
    columns: Sequence[str],
    column_of: Callable[[Row], str | None],
    layouts: Sequence[str],
    layout_of: Callable[[Row], str],
    flag: Callable[[str, Collection[str]], str] | None = None,
) -> str:
    """The score per (layout group, method) and column (e.g. a noise profile), over runs
    stratified by world, as three Markdown tables: robot-form mean and IQM, each with its
    95 % interval, and BARN's official mean (the point only, so that four profiles stay
    readable). Rows from before the score: the note. flag: as ``condition_table``'s."""
    if not is_scored(rows):
        return f"{UNSCORED_NOTE}\n"
    table = partial(
        condition_table, rows, methods, columns, column_of, layouts, layout_of, flag=flag
    )
    parts: tuple[tuple[str, str, Callable[[list[list[float]]], str]], ...] = (
        (f"Score ({SCORE_FORM}), mean [95 % interval]", ROBOT, score_cell),
        (
            f"Score ({SCORE_FORM}), IQM [95 % interval]",
            ROBOT,
            partial(score_cell, stat=iqm_interval),
        ),
        (
            "BARN's official score, mean",
            BARN,
            lambda per_world: f"{mean_interval(per_world).value:.3f}",
        ),
    )
    return "\n".join(
        f"{title}:\n\n" + table(cell=cell, scores=partial(column_scores, column=column))
        for title, column, cell in parts
    )
