"""Markdown tables in the paper's layout, from results rows (never from typed numbers).

Table I / II layout: one row per method; per world three columns Time [s], TL [m], PD [rad],
averaged over the seeds that reached the goal. A cell with no success shows ``T`` (some
episode timed out) or ``C`` (all failures were collisions) with ``--`` for TL and PD, as in
the paper. Where only some seeds succeeded the Time cell says how many, e.g. ``17.0 (2/3)``.
The best value per world and metric among methods with a success is bold (ties all bold).

The sweep's tables: one row per method and layout group, one column per noise level or
profile, each cell "successes/episodes, mean time ± half-width of its 95 % t-interval; mean
score" (the score left out for rows from before it).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.page_width import RIGHT, WorldRow, split_columns, world_table
from d3dwa_bullet.evaluation.repeats import NOISE_FREE, ONCE_NOTE, repeats_at_every_seed
from d3dwa_bullet.evaluation.stats import CellStats, Series
from d3dwa_bullet.limits import MAX_NOTE_CHARS, MAX_NOTE_VALUE_CHARS, cut_text
from d3dwa_bullet.method_specs import method_label

METRICS = (("time_s", "Time"), ("tl_m", "TL"), ("pd_rad", "PD"))


def _group(rows: Sequence[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[(r["method"], r["world"])].append(r)
    return groups


def paper_table(
    rows: Sequence[dict[str, Any]],
    methods: Sequence[str],
    worlds: Sequence[str],
    mark: Callable[[str, str], str] | None = None,
) -> str:
    """Table I layout as Markdown; mark: the text after a (method, world)'s Time cell (a
    training world's mark, ``training_worlds.cell_mark``). Worlds too many for the page's width
    are rows, each method three columns (``page_width.world_table``)."""
    groups = _group(rows)
    means: dict[tuple[str, str, str], float] = {}
    for (m, w), rs in groups.items():
        ok = [r for r in rs if r["outcome"] == "goal"]
        for key, _ in METRICS:
            if ok:
                means[(m, w, key)] = float(np.mean([r[key] for r in ok]))
    best = {}
    for w in worlds:
        for key, _ in METRICS:
            vals = [means[(m, w, key)] for m in methods if (m, w, key) in means]
            if vals:
                best[(w, key)] = round(min(vals), 2)
    table = []
    for m in methods:
        cells: list[tuple[str, ...]] = []
        for w in worlds:
            rs = groups.get((m, w), [])
            ok = [r for r in rs if r["outcome"] == "goal"]
            if not rs:
                cells.append(("", "", ""))
                continue
            if not ok:
                failed = "T" if any(r["outcome"] == "timeout" for r in rs) else "C"
                cells.append((failed + (mark(m, w) if mark else ""), "--", "--"))
                continue
            texts = []
            for key, _ in METRICS:
                val = round(means[(m, w, key)], 2)
                text = f"{val:.2f}"
                if best.get((w, key)) == val:
                    text = f"**{text}**"
                if key == "time_s" and len(ok) < len(rs):
                    text += f" ({len(ok)}/{len(rs)})"
                if key == "time_s" and mark:
                    text += mark(m, w)
                texts.append(text)
            cells.append(tuple(texts))
        table.append(WorldRow((method_label(m),), cells, title=m))
    return world_table(("Method",), ("---",), worlds, table, sub=[label for _, label in METRICS])


def _cell(s: CellStats) -> str:
    text = f"{s.successes}/{s.n}"
    if s.successes:
        text += f", {s.time_mean:.1f} s"
        if math.isfinite(s.time_lo):
            text += f" ± {(s.time_hi - s.time_lo) / 2:.1f}"
    if math.isfinite(s.score_mean):
        text += f"; {s.score_mean:.2f}"
    return text


def series_table(
    series: Series, header: Sequence[Any], flag: Callable[[str, str], str] | None = None
) -> str:
    """A sweep's series as Markdown: a row per (method, layout group), a column per x of
    header (a cell is empty where the series has no such x). flag: the text after a row's
    layout group for (method, group), e.g. how many of its worlds are training worlds. Levels
    that do not fit the page's width go to a second table (``split_columns``)."""
    body = []
    for layout, per_method in series.items():
        for m, points in per_method.items():
            by_x = dict(points)
            cells = [_cell(by_x[x]) if x in by_x else "" for x in header]
            body.append([method_label(m), layout + (flag(m, layout) if flag else ""), *cells])
    titles = ["Method", "layouts", *(str(h) for h in header)]
    return split_columns(titles, ["---", "---", *[RIGHT] * len(header)], body, keys=2)


def run_notes(recovery: str, policy_notes: Sequence[str] = (), scan_filter: str = "none") -> str:
    """The lines a results page opens with: the recovery layer of a recovery-track directory
    (none on the paper track), the scan filter (none on the paper's stack), then the config of
    each policy brought with ``--policy`` (``policy_config``)."""
    layer = (
        f"**Recovery layer `{recovery}`** (beyond the paper: progress checker and recovery "
        "behaviours around every method, docs/design/recovery.md#recovery).\n\n"
    )
    cleaned = (
        f"**Scan filter `{scan_filter}`** (beyond the paper: every method's scan filtered "
        "before the observation and the planner, docs/design/scan-filter.md#scan-filter).\n\n"
    )
    return (
        (layer if recovery != "none" else "")
        + (cleaned if scan_filter != "none" else "")
        + "".join(f"{n}\n\n" for n in policy_notes)
    )


def repeats_note(seeds: int, methods: Sequence[str], noise: str = NOISE_FREE) -> str:
    """What a page says when some of its episodes ran once for several evaluation seeds: a
    fixed or learned method without noise (:mod:`~d3dwa_bullet.evaluation.repeats`); empty
    for one seed, another noise, or only random choosers."""
    if seeds <= 1 or not any(repeats_at_every_seed(m, noise) for m in methods):
        return ""
    return ONCE_NOTE + "\n\n"


def scan_filter_of(meta: Mapping[str, Any]) -> str:
    """The scan filter a results directory's episodes ran with (its meta.json ``config``)."""
    config = meta.get("config")
    value = config.get("scan_filter", "none") if isinstance(config, Mapping) else "none"
    return value if isinstance(value, str) else "none"


def policy_notes(out: Path, meta: Mapping[str, Any]) -> list[str]:
    """meta.json's ``settings.policy_notes``: ResultsError, one line naming the file, unless
    it is a list of strings (a hand-edited file could hold anything); each cut to
    ``MAX_NOTE_CHARS``."""
    settings = meta.get("settings", {})
    notes = settings.get("policy_notes", []) if isinstance(settings, Mapping) else []
    if not isinstance(notes, list) or not all(isinstance(n, str) for n in notes):
        shown = cut_text(repr(notes), MAX_NOTE_VALUE_CHARS)
        raise ResultsError(
            f"{out / 'meta.json'}: settings.policy_notes is {shown}, expected a list of strings"
        )
    return [cut_text(n, MAX_NOTE_CHARS) for n in notes]
