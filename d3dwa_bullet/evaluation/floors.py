"""Which floor a learned method cleared: P(method > reference) against the uniform chooser over
its action set, drawn every control step (SPEC 6's floor) and held for the shipped policies'
decision period (docs/design/methods.md#methods).

A floor is cleared when the lower end of the 95 % interval of P(A > floor) over the tasks the
two share is above 0.5 (:func:`seed_tables.improvement`, its "all" record). A floor that is not
in the results, or shares no task with the method yet, is left out. Pure: results rows in, records and Markdown out.

A parameter chooser from outside the package gets the floors of its declared action set and
decision period (``external.resolve.external_floors``); a velocity planner from outside has no
action set, so no floor: its row says so and is read against DWA III, the reference
(docs/design/external-methods.md#external-methods). An external method that cannot be resolved here (its
package not installed) is left out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from d3dwa_bullet.errors import ExternalMethodError, ResultsError
from d3dwa_bullet.evaluation.seed_tables import improvement
from d3dwa_bullet.external.resolve import external_floors, resolve
from d3dwa_bullet.method_specs import floors_of, method_family, method_label

FLOORS_NOTE = (
    "The uniform chooser over each learned method's action set, drawn every control step "
    "(`random`, `random-weights`) and held for the shipped policies' decision period "
    "(`random@10`, `random-weights@10`: 1 s). P(method > floor) over the tasks both ran, 95 % "
    "stratified bootstrap over runs; a floor is cleared when the interval's lower end is above "
    "0.5 (docs/design/methods.md#floors). A chooser from outside the package: the uniform chooser over "
    "its declared action set, every step and held for its declared period; a velocity planner "
    "has no action set and is read against DWA III (`dwa3`), the reference."
)
#: The reference of a velocity planner from outside the package, which has no floor.
VELOCITY_REFERENCE = "dwa3"
CLEARED_ABOVE = 0.5
"""P(A > floor) whose interval's lower end is above this: A beats the floor."""


def floors_for(method: str) -> tuple[tuple[str, ...], bool]:
    """(floors, reference only) of a method: a learned method's floors; an external
    chooser's; (DWA III,) and True for an external velocity planner (it has no action set);
    ((), False) for any other method or an external one that cannot be resolved here."""
    family = method_family(method)
    if family == "learned":
        return floors_of(method), False
    if family != "external":
        return (), False
    try:
        resolved = resolve(method)
    except ExternalMethodError:  # its package is not installed where the tables are made
        return (), False
    if resolved.actions is None:
        return (VELOCITY_REFERENCE,), True
    return external_floors(resolved), False


def floor_records(rows: Sequence[Mapping[str, Any]], methods: Sequence[str]) -> list[dict]:
    """Per learned or external method of methods with rows, per floor with rows: {"method",
    "floor", "p", "low", "high", "tasks", "cleared", "reference_only"} (reference_only: a
    velocity planner read against DWA III, which has no floor)."""
    present = {r["method"] for r in rows}
    out = []
    for m in methods:
        if m not in present:
            continue
        floors, reference_only = floors_for(m)
        for floor in floors:
            if floor not in present:
                continue
            try:
                rec = improvement(rows, m, floor, lambda r: [])[-1]
            except ResultsError:  # an incomplete directory: no task run by both yet
                continue
            out.append({"method": m, "floor": floor, "p": rec["p"], "low": rec["low"],
                        "high": rec["high"], "tasks": rec["tasks"],
                        "cleared": rec["low"] > CLEARED_ABOVE,
                        "reference_only": reference_only})  # fmt: skip
    return out


def floor_table(records: Sequence[Mapping[str, Any]]) -> str:
    """One row per learned method and floor: P(method > floor) with its interval, and whether
    it cleared that floor. A row per floor keeps the table narrow however long a method's
    label (docs/design/metrics.md#page-width); the method is named on its first row."""
    if not records:
        return ""
    lines = [
        "| Method | Floor | P(method > floor) [95 % interval] | Cleared |",
        "|---|---|---:|---|",
    ]
    shown: set[str] = set()
    for r in records:
        m = r["method"]
        label = "" if m in shown else method_label(m)
        shown.add(m)
        floor, cleared = f"`{r['floor']}`", "yes" if r["cleared"] else "no"
        if r.get("reference_only"):  # a velocity planner: no action set, so no floor
            floor = f"{floor} (no action set: a reference, not a floor)"
        p = f"{r['p']:.2f} [{r['low']:.2f}, {r['high']:.2f}]"
        lines.append(f"| {label} | {floor} | {p} | {cleared} |")
    return "\n".join(lines) + "\n"
