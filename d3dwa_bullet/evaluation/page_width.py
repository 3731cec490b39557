"""Pages within their width budget: at most :data:`PAGE_WIDTH` characters a line, however many
worlds (docs/design/metrics.md#page-width). A page is split to fit, never joined.

- Prose: a line longer than the budget is split at spaces (:func:`fit_prose`, ``textwrap``);
  Markdown joins the lines of a paragraph back, so the page reads the same.
- A table wider than the budget keeps its key columns (e.g. the method) and splits the others
  into several tables, one under the other (:func:`split_columns`).
- A per-world table (:func:`world_table`) keeps worlds as columns, one row per method, while
  every line fits: the few worlds of the shipped set look as they always did. More worlds turn
  it round: worlds as rows, methods as columns (a method's cell is short, e.g. ``85 [70, 95]``),
  split by methods when they do not fit side by side.
- Beyond :data:`MANY_WORLDS` worlds (a whole BARN split has 50 or 250, a sweep hundreds of
  layouts) a per-world table keeps only its aggregate cells (*all*, each seed's totals) and
  says that the per-world numbers are in ``results.csv``. Why: 250 rows per table, four tables
  and each split by methods, is a page of thousands of lines that no one reads row by row,
  while the questions such a run answers are about groups, which the page keeps (the BARN rows
  per split and difficulty tercile, *all layouts*); ``results.csv`` holds every episode for a
  tool to slice.

Pure string layout of cells others computed: markers inside a cell (a training world's ``†``,
``training_worlds``) travel with it into either layout.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass

PAGE_WIDTH = 120
"""Characters a line of a page may hold (docs, README, results pages)."""
MANY_WORLDS = 60
"""Worlds up to which a per-world table lists every world; beyond, only its aggregates."""
RIGHT = "---:"
"""Markdown alignment of a numeric column."""
TITLE_WORLDS = 8
"""Worlds a page's title names one by one; more are counted (a BARN split has 50 or 250)."""


def world_span(worlds: Sequence[str]) -> str:
    """The worlds of a page's title: each name, or for more than TITLE_WORLDS the count and
    the first and last."""
    if len(worlds) <= TITLE_WORLDS:
        return ", ".join(worlds)
    return f"{len(worlds)} worlds, {worlds[0]} to {worlds[-1]}"


def _line(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def table_lines(
    header: Sequence[str], align: Sequence[str], rows: Sequence[Sequence[str]]
) -> list[str]:
    """A Markdown table's lines: header, alignment (``---`` or ``---:`` per column), rows."""
    return [_line(header), "|" + "".join(f"{a}|" for a in align), *(_line(r) for r in rows)]


def _widest(lines: Sequence[str]) -> int:
    return max((len(line) for line in lines), default=0)


def split_columns(
    header: Sequence[str],
    align: Sequence[str],
    rows: Sequence[Sequence[str]],
    keys: int = 1,
    block: int = 1,
    width: int = PAGE_WIDTH,
) -> str:
    """A Markdown table whose lines fit ``width``: as one table when it fits, else as several
    tables one under the other (a blank line between), each with the first ``keys`` columns
    and as many of the next columns as fit, ``block`` columns at a time (the columns of one
    method stay together), shared out evenly between the tables when that fits too. A block
    too wide on its own gets a table to itself."""
    n = len(header)
    blocks = [list(range(s, min(s + block, n))) for s in range(keys, n, block)]
    groups: list[list[int]] = []
    for cols in blocks:  # greedy: as many blocks a table as fit
        trial = [*(groups[-1] if groups else []), *cols]
        if groups and _widest(_pick(header, align, rows, keys, trial)) <= width:
            groups[-1] = trial
        else:
            groups.append(cols)
    if len(groups) > 1:  # as many tables, but the blocks shared out evenly when they fit
        size = -(-len(blocks) // len(groups))
        even = [sum(blocks[i : i + size], []) for i in range(0, len(blocks), size)]
        if all(_widest(_pick(header, align, rows, keys, g)) <= width for g in even):
            groups = even
    tables = ["\n".join(_pick(header, align, rows, keys, g)) + "\n" for g in groups or [[]]]
    return "\n".join(tables)


def _pick(
    header: Sequence[str],
    align: Sequence[str],
    rows: Sequence[Sequence[str]],
    keys: int,
    cols: Sequence[int],
) -> list[str]:
    take = [*range(keys), *cols]
    return table_lines(
        [header[c] for c in take], [align[c] for c in take], [[r[c] for c in take] for r in rows]
    )


@dataclass(frozen=True)
class WorldRow:
    """One row of a per-world table in its wide layout: a method, or one training seed of it."""

    lead: Sequence[str]
    """The cells before the worlds, e.g. (method label, runs)."""
    cells: Sequence[Sequence[str]]
    """Per world (in the table's order), its cells: one per sub-column (e.g. Time, TL, PD)."""
    tail: Sequence[str] = ()
    """The cells after the worlds, e.g. the *all* cell."""
    title: str | None = None
    """Its column's title when worlds are rows, short (a method's name, not its label);
    None: ``lead[0]``."""


def world_table(
    lead: Sequence[str],
    lead_align: Sequence[str],
    worlds: Sequence[str],
    rows: Sequence[WorldRow],
    sub: Sequence[str] = ("",),
    tail: Sequence[str] = (),
    lead_table: bool = True,
    width: int = PAGE_WIDTH,
    many: int = MANY_WORLDS,
) -> str:
    """A per-world table as Markdown whose lines fit ``width`` (module docstring). lead: the
    header cells before the worlds (e.g. Method, runs), lead_align their alignment; sub: a
    world's sub-column titles (a column ``"<world> <sub>"`` each); tail: the header cells after
    the worlds (e.g. ``all``), right-aligned like the worlds'.

    Worlds as columns while every line fits and there are at most ``many`` worlds. Else worlds
    as rows under a ``World`` column and each row's cells as a column block titled by its
    ``title`` (its first sub-column "<title> <sub>", the others "<sub>"; split by blocks to
    fit), the tail cells as rows after the worlds; with lead_table, first a table of each
    title and its lead cells (e.g. the method's label and runs). Beyond
    ``many`` worlds: the lead and tail cells only, rows as in the wide layout, and a line
    saying the per-world numbers are in results.csv."""
    n_cells = len(worlds) * len(sub) + len(tail)
    header = [*lead, *(f"{w} {s}".rstrip() for w in worlds for s in sub), *tail]
    align = [*lead_align, *[RIGHT] * n_cells]
    body = [[*r.lead, *(c for cell in r.cells for c in cell), *r.tail] for r in rows]
    lines = table_lines(header, align, body)
    if len(worlds) <= many and _widest(lines) <= width:
        return "\n".join(lines) + "\n"
    if len(worlds) > many:
        note = (
            f"Per-world cells of these {len(worlds)} worlds: results.csv (one row per episode); "
            f"a page lists at most {many} worlds (docs/design/metrics.md#page-width).\n"
        )
        if not tail:
            return note
        kept = split_columns(
            [*lead, *tail], [*lead_align, *[RIGHT] * len(tail)],
            [[*r.lead, *r.tail] for r in rows], keys=len(lead), width=width,
        )  # fmt: skip
        return note + "\n" + kept
    titles = [r.lead[0] if r.title is None else r.title for r in rows]
    parts = []
    if lead_table:
        parts.append(
            split_columns(
                ["name", *lead], ["---", *lead_align],
                [[t, *r.lead] for t, r in zip(titles, rows, strict=True)], width=width,
            )
        )  # fmt: skip
    pad = [""] * (len(sub) - 1)
    header = ["World"] + [
        f"{t} {s}".rstrip() if k == 0 else s for t in titles for k, s in enumerate(sub)
    ]
    body = [[w, *(c for r in rows for c in r.cells[i])] for i, w in enumerate(worlds)]
    body += [[t, *(c for r in rows for c in (r.tail[j], *pad))] for j, t in enumerate(tail)]
    align = ["---", *[RIGHT] * (len(rows) * len(sub))]
    parts.append(split_columns(header, align, body, keys=1, block=len(sub), width=width))
    return "\n".join(parts)


def fit_prose(text: str, width: int = PAGE_WIDTH) -> str:
    """text with every line longer than ``width`` split at spaces, except table rows (``|``,
    laid out to fit by the functions above) and headings; a quoted line's continuations keep
    the ``> ``, a list item's are indented. Lines that fit are left as they are."""
    out = []
    for line in text.split("\n"):
        if len(line) <= width or line.startswith(("|", "#")):
            out.append(line)
            continue
        indent = "> " if line.startswith("> ") else "  " if line.startswith("- ") else ""
        wrapped = textwrap.wrap(
            line, width, subsequent_indent=indent, break_long_words=False,
            break_on_hyphens=False,
        )  # fmt: skip
        out.extend(wrapped or [line])
    return "\n".join(out)
