"""Results on a sweep's unseen layouts by generator style: the rows its page and ``compare``
add when the layouts come from more than one style (``--styles``).

A generated layout's style is in its name (``R2-style-s2147483650``) and is fixed before any
method ran, so each style is a stratum of the sweep, as a BARN world's difficulty tercile is;
the pooled ``generated`` rows stay beside them.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from functools import cache
from typing import Any

from d3dwa_bullet.evaluation.score_tables import score_condition_tables
from d3dwa_bullet.evaluation.seed_tables import condition_table
from d3dwa_bullet.world.generator import generated_style

Row = Mapping[str, Any]

_style = cache(generated_style)  # a sweep has many rows of a few hundred layouts


def style_of(row: Row) -> str | None:
    """The generator style of a sweep row's unseen layout; None for any other row (a shipped
    or given world, a BARN world, an ``eval`` row)."""
    return _style(row["world"]) if row.get("layout") == "generated" else None


def styles_present(rows: Sequence[Row]) -> list[str]:
    """The styles of the rows' unseen layouts, sorted; empty when there are none."""
    return sorted({s for r in rows if (s := style_of(r)) is not None})


def style_section(
    rows: Sequence[Row],
    methods: Sequence[str],
    columns: Sequence[str],
    column_of: Callable[[Row], str | None],
    flag: Callable[[str, Collection[str]], str] | None = None,
) -> str:
    """Markdown: success and score over runs per style of the unseen layouts, one column per
    ``columns`` (e.g. the noise profile); "" unless the rows hold two styles or more."""
    styles = styles_present(rows)
    if len(styles) < 2:
        return ""
    generated = [r for r in rows if style_of(r) is not None]

    def group(r: Row) -> str:
        return str(style_of(r))

    return (
        "\n### Unseen layouts by generator style\n\nEach style is a stratum fixed before any "
        "method ran; *all layouts* here are the unseen layouts of every style (the *generated* "
        "rows above). Success rate [%] averaged over a style's layouts, 95 % stratified "
        "bootstrap over runs.\n\n"
        + condition_table(generated, methods, columns, column_of, styles, group, flag=flag)
        + "\nThe score (docs/design/score.md#score) per style, as above.\n\n"
        + score_condition_tables(generated, methods, columns, column_of, styles, group, flag)
    )
