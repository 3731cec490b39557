"""Results over training seeds: per-run scores, the seed-aggregated tables, and comparisons.

A *run* is one independent trial of a method: for a learned method one training seed
(``policy_seed``), whose evaluation episodes are averaged into one score per task; a fixed
method has no training, so each of its evaluation seeds is a run. A *task* is one world
under one noise setting. Intervals resample runs within each task (the stratified bootstrap
of :mod:`d3dwa_bullet.evaluation.seed_stats`), so they cover the spread between training
seeds, not only between episodes.

- success: per run, the fraction of its episodes that reached the goal;
- time: per run, the mean time to goal of its successful episodes (runs without a success
  have none), summarised as the interquartile mean (IQM) over runs;
- score: per run, the mean episode score (docs/design/score.md#score; failures score 0), in
  :mod:`~d3dwa_bullet.evaluation.score_tables`;
- improvement: P(A > B), the chance that a run of A has a higher success score than a run
  of B on a task (ties half), averaged over tasks (Agarwal et al., 2021).

Pure functions of results rows (as :func:`~d3dwa_bullet.evaluation.results.read_results`
returns them): no simulator, no torch.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Collection, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.page_width import (
    PAGE_WIDTH,
    RIGHT,
    WorldRow,
    split_columns,
    world_table,
)
from d3dwa_bullet.evaluation.seed_stats import (
    Interval,
    iqm_interval,
    mean_interval,
    probability_of_improvement,
)
from d3dwa_bullet.method_specs import method_family, method_label, needs_policy

Row = Mapping[str, Any]
Run = tuple[str, int]
"""("train", policy seed) or ("eval", evaluation seed) (module docstring)."""


def run_of(row: Row) -> Run:
    """The run a row belongs to."""
    seed = row["policy_seed"]
    return ("train", seed) if seed is not None else ("eval", row["seed"])


def check_not_mixed(rows: Sequence[Row], where: str) -> None:
    """ResultsError if one method has rows with a policy seed and rows without: its single
    policy and its seeds are different experiments and cannot share one interval."""
    kinds: dict[str, set[bool]] = defaultdict(set)
    for r in rows:
        kinds[r["method"]].add(r["policy_seed"] is None)
    for method, seen in kinds.items():
        if len(seen) > 1:
            raise ResultsError(
                f"{where}: method {method!r} has rows of a single policy (empty policy_seed) "
                "and rows of training seeds; evaluate it one way per results directory"
            )


def _by_run(rows: Sequence[Row]) -> dict[Run, list[Row]]:
    runs: dict[Run, list[Row]] = defaultdict(list)
    for r in rows:
        runs[run_of(r)].append(r)
    return dict(sorted(runs.items()))


def success_scores(rows: Sequence[Row]) -> list[float]:
    """One success score per run of rows (one method on one task), in run order."""
    return [float(np.mean([r["outcome"] == "goal" for r in rs])) for rs in _by_run(rows).values()]


def column_scores(rows: Sequence[Row], column: str) -> list[float]:
    """Per run of rows (one method on one task), the mean of a numeric column (e.g. the
    episode score, failures 0), in run order."""
    return [float(np.mean([r[column] for r in rs])) for rs in _by_run(rows).values()]


def time_scores(rows: Sequence[Row]) -> list[float]:
    """Per run with a success, the mean time to goal of its successes, s."""
    out = []
    for rs in _by_run(rows).values():
        times = [r["time_s"] for r in rs if r["outcome"] == "goal"]
        if times:
            out.append(float(np.mean(times)))
    return out


def _cells(rows: Sequence[Row]) -> dict[tuple[str, str], list[Row]]:
    cells: dict[tuple[str, str], list[Row]] = defaultdict(list)
    for r in rows:
        cells[(r["method"], r["world"])].append(r)
    return cells


def _n_runs(rows: Sequence[Row]) -> tuple[int, int]:
    """(training seeds, episodes) of a method's rows (0 training seeds: a method without a
    policy, or a single policy)."""
    return len({r["policy_seed"] for r in rows if r["policy_seed"] is not None}), len(rows)


def one_run_each(per_world: Sequence[Sequence[float]]) -> bool:
    """Every world holds one run: the stratified bootstrap then resamples nothing and its
    interval is the point itself, so a cell shows the value alone (never ``100 [100, 100]``)."""
    return all(len(s) == 1 for s in per_world)


def _rate(i: Interval) -> str:
    return f"{100 * i.value:.0f} [{100 * i.low:.0f}, {100 * i.high:.0f}]"


def rate_cell(per_world: Sequence[Sequence[float]]) -> str:
    """Success in % over runs: "mean [low, high]", or the mean alone with one run a world."""
    i = mean_interval(per_world)
    return f"{100 * i.value:.0f}" if one_run_each(per_world) else _rate(i)


def _time(scores: list[list[float]]) -> str:
    """IQM time over runs [s] "value [low, high]" (the value alone with one run a world; "--"
    without a success)."""
    scores = [s for s in scores if s]
    if not scores:
        return "--"
    i = iqm_interval(scores)
    return (
        f"{i.value:.1f}" if one_run_each(scores) else f"{i.value:.1f} [{i.low:.1f}, {i.high:.1f}]"
    )


def _runs_label(method: str, rows: Sequence[Row]) -> str:
    """method: the method's name (not a key such as 'dwa3 [A]')."""
    seeds, n = _n_runs(rows)
    episodes = f"{n} episode{'s' * (n != 1)}"
    if seeds:
        return f"{seeds} training seed{'s' * (seeds != 1)}, {episodes}"
    kind = method_family(method) if not needs_policy(method) else "one policy, no training seeds"
    return f"{kind}, {episodes}"


def seed_tables(
    rows: Sequence[Row],
    methods: Sequence[str],
    worlds: Sequence[str],
    sides: Mapping[str, tuple[str, str]] | None = None,
    mark: Callable[[str, str], str] | None = None,
) -> str:
    """Success rate and time per (method, world) over runs, with 95 % intervals, as Markdown:
    one table of success rates (%), one of IQM times (s); an "all" column aggregates the
    worlds (mean success over worlds, IQM of time over every run and world). sides: for a
    row's method that is a key, not a method (one method on both sides of a comparison),
    the (method, label) it stands for. mark: the text after a (row's method or key, world)
    cell (a training world's mark, ``training_worlds.cell_mark``)."""
    cells = _cells(rows)
    named = {m: (m, method_label(m)) for m in methods} | dict(sides or {})
    success: list[WorldRow] = []
    timing: list[WorldRow] = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        if not mine:
            continue
        s_cells, t_cells, s_all, t_all = [], [], [], []
        for w in worlds:
            rs = cells.get((m, w), [])
            if not rs:
                s_cells.append(("",))
                t_cells.append(("",))
                continue
            s, t = success_scores(rs), time_scores(rs)
            s_all.append(s)
            t_all.append(t)
            flag = mark(m, w) if mark else ""
            s_cells.append((rate_cell([s]) + flag,))
            t_cells.append((_time([t]) + flag,))
        lead = (named[m][1], _runs_label(named[m][0], mine))
        success.append(WorldRow(lead, s_cells, (rate_cell(s_all),), m))
        timing.append(WorldRow(lead, t_cells, (_time(t_all),), m))
    table = partial(world_table, ("Method", "runs"), ("---", "---"), worlds, tail=("all",))
    return (
        "### Success rate [%], 95 % interval over runs (none where a cell has one run)\n\n"
        + table(success)
        + "\n### Time to goal, IQM over runs [s], 95 % interval\n\n"
        + table(timing, lead_table=False)
    )


def per_seed_table(
    rows: Sequence[Row],
    methods: Sequence[str],
    worlds: Sequence[str],
    mark: Callable[[str, str], str] | None = None,
) -> str:
    """One row per (method, training seed): successes/episodes and mean time per world, then
    over every world the success rate and the mean score in both forms (robot, BARN's;
    ``--`` for rows from before the score). Fixed methods get one row over all their
    evaluation seeds. mark: the text after a (method, world) cell (see seed_tables)."""
    cells = _cells(rows)
    scored = all(r.get("score") is not None for r in rows)
    table: list[WorldRow] = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        seeds = sorted({r["policy_seed"] for r in mine}, key=lambda k: (k is not None, k))
        for k in seeds:
            parts, n_ok, n_all = [], 0, 0
            for w in worlds:
                rs = [r for r in cells.get((m, w), []) if r["policy_seed"] == k]
                ok = [r["time_s"] for r in rs if r["outcome"] == "goal"]
                n_ok, n_all = n_ok + len(ok), n_all + len(rs)
                if not rs:
                    parts.append("")
                elif ok:
                    parts.append(f"{len(ok)}/{len(rs)}, {np.mean(ok):.1f} s")
                else:
                    n_c = sum(r["outcome"] == "collision" for r in rs)
                    parts.append(f"0/{len(rs)} ({n_c} C, {len(rs) - n_c} T)")
                if rs and mark:
                    parts[-1] += mark(m, w)
            rate = f"{100 * n_ok / n_all:.0f} %" if n_all else ""
            mine_k = [r for r in mine if r["policy_seed"] == k]
            score = barn = "--"
            if scored and mine_k:
                score = f"{np.mean([r['score'] for r in mine_k]):.2f}"
                barn = f"{np.mean([r['score_barn'] for r in mine_k]):.3f}"
            seed = "--" if k is None else str(k)
            title = m + ("" if k is None else f" seed {k}")
            table.append(
                WorldRow((method_label(m), seed), [(p,) for p in parts], (rate, score, barn), title)
            )
    return world_table(
        ("Method", "training seed"), ("---", "---:"), worlds, table,
        tail=("success", "score", "BARN"),
    )  # fmt: skip


def improvement(
    rows: Sequence[Row], a: str, b: str, groups_of: Callable[[Row], Sequence[str]]
) -> list[dict[str, Any]]:
    """P(a > b) on success per group of tasks, and over every task the two methods share.

    groups_of names the groups a row's task belongs to, finest first (e.g. its layout group
    under its noise, then all layouts under that noise). Returns records {"group", "tasks",
    "runs_a", "runs_b", "p", "low", "high"}: the finest groups in first-seen order, then the
    coarser ones (left out where they hold the same tasks as "all"), then "all".
    ResultsError if the methods share no task."""
    tasks: dict[tuple[str, str], dict[str, list[Row]]] = defaultdict(lambda: defaultdict(list))
    member: dict[tuple[str, str], Sequence[str]] = {}
    for r in rows:
        if r["method"] in (a, b):
            task = (r["world"], r["noise"])
            tasks[task][r["method"]].append(r)
            member.setdefault(task, groups_of(r))
    shared = [t for t, per in tasks.items() if a in per and b in per]
    if not shared:
        raise ResultsError(f"methods {a!r} and {b!r} share no (world, noise) in these results")
    # the finest groups first, then the coarser ones, each at the deepest place a row puts it
    # ("all layouts" after "generated" when a style comes first), in first-seen order within
    # a level
    level_of: dict[str, int] = {}
    for t in shared:
        for level, name in enumerate(member[t]):
            level_of[name] = max(level, level_of.get(name, level))
    seen = {name: i for i, name in enumerate(dict.fromkeys(g for t in shared for g in member[t]))}
    records = []
    for name in [*sorted(level_of, key=lambda g: (level_of[g], seen[g])), "all"]:
        members = shared if name == "all" else [t for t in shared if name in member[t]]
        if name != "all" and level_of[name] > 0 and len(members) == len(shared):
            continue  # a coarser group with the same tasks as "all": that row says it
        xa = [success_scores(tasks[t][a]) for t in members]
        xb = [success_scores(tasks[t][b]) for t in members]
        p = probability_of_improvement(xa, xb)
        records.append({
            "group": name, "tasks": len(members),
            "runs_a": max(len(x) for x in xa), "runs_b": max(len(x) for x in xb),
            "p": p.value, "low": p.low, "high": p.high,
        })  # fmt: skip
    return records


def improvement_table(
    records: Sequence[Mapping[str, Any]], a: str, b: str, labels: Mapping[str, str] | None = None
) -> str:
    """The records of :func:`improvement` as Markdown; labels: a's and b's column labels
    where they are not the methods' (e.g. one method with and without recovery). Columns that
    do not fit the page's width go to a second table (``split_columns``); labels too long for
    a column of their own (two results directories' paths) are written A and B, as the page's
    text names them."""
    names = labels or {}
    # a label given is not parsed: one method on both sides is keyed 'random@10 [A]'
    la, lb = (names[m] if m in names else method_label(m) for m in (a, b))
    widest_group = max((len(r["group"]) for r in records), default=0)
    if len(f"| {'-' * widest_group} | P({la} > {lb}) |") > PAGE_WIDTH:  # not even on its own
        la, lb = "A", "B"
    paired = any("paired_p" in r for r in records)
    header = ["tasks", "n", f"runs {la}", f"runs {lb}", f"P({la} > {lb})", "95 % interval"]
    align = ["---", RIGHT, RIGHT, RIGHT, RIGHT, "---"]
    if paired:
        header += ["pairs", "A better / worse", "paired p (A > B)"]
        align += [RIGHT] * 3
    body = []
    for r in records:
        cells = [r["group"], str(r["tasks"]), str(r["runs_a"]), str(r["runs_b"]),
                 f"{r['p']:.2f}", f"[{r['low']:.2f}, {r['high']:.2f}]"]  # fmt: skip
        if paired:
            p = r.get("paired_p")
            cells += [str(r.get("paired_units", 0)),
                      f"{r.get('paired_wins', 0)} / {r.get('paired_losses', 0)}",
                      "--" if p is None else f"{p:.3g}"]  # fmt: skip
        body.append(cells)
    return split_columns(header, align, body)


def condition_table(
    rows: Sequence[Row],
    methods: Sequence[str],
    columns: Sequence[str],
    column_of: Callable[[Row], str | None],
    layouts: Sequence[str],
    layout_of: Callable[[Row], str],
    cell: Callable[[list[list[float]]], str] | None = None,
    scores: Callable[[Sequence[Row]], list[float]] = success_scores,
    flag: Callable[[str, Collection[str]], str] | None = None,
) -> str:
    """Success over runs per (layout group, method) and column (e.g. a noise profile): the
    mean over the group's worlds with its stratified interval, as Markdown. Rows whose
    column_of is None are left out; an "all layouts" group follows when there are several.
    scores: the per-run scores of one world's rows (default success); cell: the text of a
    cell from the per-world lists of them (default the mean [interval] in %). flag: the text
    after a row's group for (method, the group's worlds), e.g. how many are training worlds.
    Columns that do not fit the page's width go to a second table (``split_columns``)."""
    cell = cell or rate_cell
    groups = [*layouts, "all layouts"] if len(layouts) > 1 else list(layouts)
    cells: dict[tuple[str, str, str], dict[str, list[Row]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        column = column_of(r)
        if column is None:
            continue
        for g in (layout_of(r), "all layouts"):
            cells[(g, r["method"], column)][r["world"]].append(r)
    body = []
    for g in groups:
        for m in methods:
            parts: list[str] = []
            seen: set[str] = set()
            for c in columns:
                worlds = cells.get((g, m, c))
                parts.append(cell([scores(rs) for rs in worlds.values()]) if worlds else "")
                seen.update(worlds or ())
            if any(parts):
                body.append([method_label(m), g + (flag(m, seen) if flag else ""), *parts])
    header = ["Method", "layouts", *columns]
    return split_columns(header, ["---", "---", *[RIGHT] * len(columns)], body, keys=2)
