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
    "its declared action set, every step and held for its declared period."
)
REFERENCE_NOTE = (
    "A velocity planner from outside the package has no action set, so no floor: it is read "
    "against DWA III (`dwa3`), the reference. P(method > reference) over the tasks both ran, "
    "95 % stratified bootstrap over runs; a reading, not a floor cleared."
)
#: Said in place of an interval when each side has one run: the bootstrap has nothing to draw.
ONE_RUN_EACH = "no interval (one run each)"
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
            one_run = rec["runs_a"] == rec["runs_b"] == 1  # a zero-width interval: none
            out.append({"method": m, "floor": floor, "p": rec["p"], "low": rec["low"],
                        "high": rec["high"], "tasks": rec["tasks"], "one_run_each": one_run,
                        "cleared": not one_run and rec["low"] > CLEARED_ABOVE,
                        "reference_only": reference_only})  # fmt: skip
    return out


def chance_sections(
    rows: Sequence[Mapping[str, Any]], methods: Sequence[str], heading: str = "##", where: str = ""
) -> str:
    """The Markdown sections "Against chance" (each learned or external chooser against its
    floors) and, apart, "Against the reference" (each external velocity planner against DWA
    III, which is no floor); empty when neither has a row. heading: the Markdown level; where:
    words after each title (" (every layout and condition)")."""
    records = floor_records(rows, methods)
    floors = [r for r in records if not r["reference_only"]]
    references = [r for r in records if r["reference_only"]]
    out = ""
    if floors:
        out += f"\n{heading} Against chance{where}\n\n{FLOORS_NOTE}\n\n{floor_table(floors)}"
    if references:
        out += (
            f"\n{heading} Against the reference{where}\n\n{REFERENCE_NOTE}\n\n"
            f"{reference_table(references)}"
        )
    return out


def _p_cell(r: Mapping[str, Any]) -> str:
    if r.get("one_run_each"):
        return f"{r['p']:.2f}, {ONE_RUN_EACH}"
    return f"{r['p']:.2f} [{r['low']:.2f}, {r['high']:.2f}]"


def floor_table(records: Sequence[Mapping[str, Any]]) -> str:
    """One row per learned or external chooser and floor: P(method > floor) with its interval,
    and whether it cleared that floor ("--" with one run each side: no interval to read). A row
    per floor keeps the table narrow however long a method's label (docs/design/metrics.md#page-width);
    the method is named on its first row."""
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
        cleared = "--" if r.get("one_run_each") else ("yes" if r["cleared"] else "no")
        lines.append(f"| {label} | `{r['floor']}` | {_p_cell(r)} | {cleared} |")
    return "\n".join(lines) + "\n"


def reference_table(records: Sequence[Mapping[str, Any]]) -> str:
    """One row per velocity planner: P(method > DWA III) with its interval; no "cleared"
    column, since a reference is not a floor."""
    lines = [
        "| Method | Reference | P(method > reference) [95 % interval] | Tasks |",
        "|---|---|---:|---:|",
    ]
    for r in records:
        lines.append(
            f"| {method_label(r['method'])} | `{r['floor']}` | {_p_cell(r)} | {r['tasks']} |"
        )
    return "\n".join(lines) + "\n"
