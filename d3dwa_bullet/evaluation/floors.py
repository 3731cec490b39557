"""Which floor a learned method cleared: P(method > reference) against the uniform chooser over
its action set, drawn every control step (SPEC 6's floor) and held for the shipped policies'
decision period (docs/design.md#methods).

A floor is cleared when the lower end of the 95 % interval of P(A > floor) over the tasks the
two share is above 0.5 (:func:`seed_tables.improvement`, its "all" record). A floor that is not
in the results, or shares no task with the method yet, is left out. Pure: results rows in, records and Markdown out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.seed_tables import improvement
from d3dwa_bullet.method_specs import floors_of, method_family, method_label

FLOORS_NOTE = (
    "The uniform chooser over each learned method's action set, drawn every control step "
    "(`random`, `random-weights`) and held for the shipped policies' decision period "
    "(`random@10`, `random-weights@10`: 1 s). P(method > floor) over the tasks both ran, 95 % "
    "stratified bootstrap over runs; a floor is cleared when the interval's lower end is above "
    "0.5 (docs/design.md#floors)."
)
CLEARED_ABOVE = 0.5
"""P(A > floor) whose interval's lower end is above this: A beats the floor."""


def floor_records(rows: Sequence[Mapping[str, Any]], methods: Sequence[str]) -> list[dict]:
    """Per learned method of methods with rows, per floor with rows: {"method", "floor",
    "p", "low", "high", "tasks", "cleared"}."""
    present = {r["method"] for r in rows}
    out = []
    for m in methods:
        if m not in present or method_family(m) != "learned":
            continue
        for floor in floors_of(m):
            if floor not in present:
                continue
            try:
                rec = improvement(rows, m, floor, lambda r: [])[-1]
            except ResultsError:  # an incomplete directory: no task run by both yet
                continue
            out.append({"method": m, "floor": floor, "p": rec["p"], "low": rec["low"],
                        "high": rec["high"], "tasks": rec["tasks"],
                        "cleared": rec["low"] > CLEARED_ABOVE})  # fmt: skip
    return out


def floor_table(records: Sequence[Mapping[str, Any]]) -> str:
    """One row per learned method: P(> each floor) with its interval, and which it cleared."""
    if not records:
        return ""
    by_method: dict[str, list[Mapping[str, Any]]] = {}
    for r in records:
        by_method.setdefault(r["method"], []).append(r)
    lines = ["| Method | floor: P(method > floor) [95 % interval] | cleared |", "|---|---|---|"]
    for m, recs in by_method.items():
        cells = "; ".join(
            f"`{r['floor']}`: {r['p']:.2f} [{r['low']:.2f}, {r['high']:.2f}]" for r in recs
        )
        cleared = ", ".join(f"`{r['floor']}`" for r in recs if r["cleared"]) or "none"
        lines.append(f"| {method_label(m)} | {cells} | {cleared} |")
    return "\n".join(lines) + "\n"
