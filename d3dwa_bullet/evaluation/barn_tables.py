"""Results on BARN worlds by split and by difficulty tercile: the rows tables add when a run
holds BARN worlds (``d3dwa eval --suite barn``, ``d3dwa sweep --suite barn``).

A BARN world's split group is its ``World.group`` (``barn-challenge``, ``barn-train``) and its
difficulty group its tercile (``barn-easy``, ``barn-middle``, ``barn-hard``;
:mod:`d3dwa_bullet.world.barn_difficulty`), both fixed before any method ran.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any

from d3dwa_bullet.evaluation.seed_tables import condition_table
from d3dwa_bullet.world.barn import SPLIT_GROUPS, barn_index, barn_split
from d3dwa_bullet.world.barn_difficulty import TERCILE_GROUPS, TERCILE_MEASURE, barn_tercile_group

Row = Mapping[str, Any]
SPLIT_ORDER = tuple(SPLIT_GROUPS.values())
"""Split groups in table order: challenge, train."""
TERCILE_ORDER = TERCILE_GROUPS
"""Tercile groups in table order: easy, middle, hard."""


def split_group(world: str) -> str | None:
    """``barn-challenge`` or ``barn-train`` for a BARN world's name, else None."""
    index = barn_index(world)
    return None if index is None else SPLIT_GROUPS[barn_split(index)]


def tercile_group(world: str) -> str | None:
    """``barn-easy``, ``barn-middle`` or ``barn-hard`` for a BARN world's name, else None."""
    index = barn_index(world)
    return None if index is None else barn_tercile_group(index)


def barn_section(
    rows: Sequence[Row],
    methods: Sequence[str],
    columns: Sequence[str],
    column_of: Callable[[Row], str | None],
    flag: Callable[[str, Collection[str]], str] | None = None,
    label: str = "",
) -> str:
    """Markdown: success over runs per BARN split (when the rows hold both) and per
    difficulty tercile, one column per ``columns`` (e.g. the noise profile); "" without
    BARN rows. Non-BARN rows are left out. flag: the text after a row's group for (method,
    its worlds): how many are that method's training worlds (``training_worlds.group_flag``).
    label: the conditions its heading names (split, profile, recovery layer), if any."""
    barn = [r for r in rows if barn_index(r["world"]) is not None]
    if not barn:
        return ""
    parts = [
        f"\n## BARN by split and difficulty{f' ({label})' if label else ''}\n\n"
        f"Success rate [%] averaged over the BARN worlds of a group, 95 % stratified bootstrap "
        f"over runs. Terciles rank all 300 worlds by `{TERCILE_MEASURE}` (mean clearance along "
        "BARN's reference path), fixed before any method ran (docs/worlds.md#barn).\n\n"
    ]
    for order, group_of in ((SPLIT_ORDER, split_group), (TERCILE_ORDER, tercile_group)):
        present = [g for g in order if any(group_of(r["world"]) == g for r in barn)]
        if order is SPLIT_ORDER and len(present) < 2:
            continue  # one split: its rows are the tercile table's "all layouts"
        table = condition_table(
            barn, methods, columns, column_of, present, _layout(group_of), flag=flag
        )
        parts.append(table + "\n")
    return "".join(parts)


def _layout(group_of: Callable[[str], str | None]) -> Callable[[Row], str]:
    """A row's group by ``group_of`` of its world (only BARN rows reach it)."""
    return lambda r: str(group_of(r["world"]))
