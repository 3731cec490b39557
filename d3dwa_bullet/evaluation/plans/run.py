"""Running a sequential plan: look by look, every open cell read, logged, stopped once it reads.

:func:`run_plan` drives any source of episodes through a plan (docs/design/sequential-plans.md):
per family, the layouts in the plan's order; at each look the episodes the open cells still
need (a side under a profile runs only while an open cell of that profile names it; a side is
named by ``Cell.sides``: its method, unless the cell reads across a setting) are asked of
``run`` (every key asked so far, so a source that skips finished episodes resumes), then each
open cell is read on the headline metric (its question's estimator, ``looks.ESTIMATORS``)
against the look's boundaries (``student.rule_boundaries``: for the t) at the cell's level (the
plan's multiplicity control, ``recycling.read_look``: alpha, alpha / m, or Holm's recycled
level, carried from family to family); a cell that reads is closed; the family stops at its
maximum or once no cell is open. Every look of every cell, with its level, is a line of
``looks.jsonl`` (rewritten whole after each look: a resumed run reads the same rows and
so writes the same lines), and ``looks.md`` tabulates them. Each line also carries ``beside``: the
estimate of every other metric the plan gives a margin (success, BARN's score), on the same
layouts, read by nobody's rule (a stop is the headline's). ``order.json`` holds each family's
layouts in the plan's order, so a reader knows which layouts a look read (its first ``layouts``).

A run records what it began with in ``plan.json`` (the plan file's sha256 and the code's
identity, :func:`code_identity`); resuming with either changed is refused in one line saying
what changed (:func:`check_resume`).
"""

from __future__ import annotations

import json
import subprocess
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.page_width import split_columns
from d3dwa_bullet.evaluation.paired import Row
from d3dwa_bullet.evaluation.plans.looks import DECISIONS, ESTIMATORS, INCONCLUSIVE, OPEN
from d3dwa_bullet.evaluation.plans.order import layout_order
from d3dwa_bullet.evaluation.plans.plan_file import Cell, Family, Plan
from d3dwa_bullet.evaluation.plans.recycling import LevelBounds, Levels, read_look
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.loading import load_json

PLAN_RECORD = "plan.json"
LOOKS_LOG = "looks.jsonl"
LOOKS_PAGE = "looks.md"
ORDER_RECORD = "order.json"
Key = tuple[str, str, str]
"""(layout, profile, side): the episodes of one side of a cell (its method, or its
``plan_file.side_label``: ``Cell.sides``) on one layout under one profile."""
Source = Callable[[Sequence[Key]], Sequence[Row]]
"""Runs (or finds) the episodes of every key given and returns their rows."""


def code_identity() -> str:
    """The package version and, in a git checkout, its commit ('0.1.0+<sha>', with '-dirty'
    when files differ from it); '0.1.0' alone outside a checkout."""
    here = Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()  # fmt: skip
        dirty = subprocess.run(["git", "status", "--porcelain", "--", str(here.parents[1])], cwd=here,
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return __version__
    return f"{__version__}+{sha[:12]}{'-dirty' if dirty else ''}"


def check_resume(out: Path, plan: Plan, code: str) -> None:
    """Record the plan's sha256 and the code in out/plan.json on a first run; on a resumed one,
    ConfigError naming what changed since the run began."""
    path = out / PLAN_RECORD
    if not path.exists():
        atomic_write_text(
            path, json.dumps({"plan": plan.name, "sha256": plan.digest, "code": code}, indent=1)
        )
        return
    began = load_json(path, ResultsError)
    if not isinstance(began, dict) or not {"sha256", "code"} <= set(began):
        raise ResultsError(f"{path}: not a plan record (needs sha256 and code)")
    if began["sha256"] != plan.digest:
        raise ConfigError(
            f"{out}: the plan file changed since this run began (sha256 {str(began['sha256'])[:12]} -> "
            f"{plan.digest[:12]}); resume with the plan it began with, or start a new --out"
        )
    if began["code"] != code:
        raise ConfigError(
            f"{out}: the code changed since this run began ({began['code']} -> {code}); resume with the "
            "code it began with, or start a new --out"
        )


def _family_order(plan: Plan, family: Family, strata: Mapping[str, str]) -> list[str]:
    """The family's layouts (strata: layout -> its stratum) in the plan's order; ConfigError
    when they are not as many as its maximum."""
    by = {s: sorted(layout for layout, st in strata.items() if st == s) for s in family.strata}
    total = sum(map(len, by.values()))
    if total != family.maximum:
        raise ConfigError(
            f"plan family {family.name}: maximum {family.maximum}, but the run has {total} layouts "
            f"of its strata ({', '.join(family.strata)})"
        )
    return layout_order(by, plan.order_seed)


def _read(
    plan: Plan, cell: Cell, profile: str, rows: Sequence[Row], metric: str = ""
) -> tuple[float, float, float]:
    a, b = cell.sides
    try:
        e = ESTIMATORS[cell.question](rows, a, b, metric or plan.headline)
    except ValueError as err:  # fewer than two layouts, or a value missing
        raise ResultsError(f"cell {a},{b} under {profile}: {err}") from err
    return e.mean, e.se, e.df


def _beside(plan: Plan, cell: Cell, profile: str, rows: Sequence[Row]) -> dict[str, Any]:
    """{metric: {difference, se, df}} of every non-headline metric with a margin (None where
    the rows cannot give it: a value missing)."""
    out: dict[str, Any] = {}
    for metric in (m for m in plan.margins if m != plan.headline):
        try:
            d, se, df = _read(plan, cell, profile, rows, metric)
        except ResultsError:
            out[metric] = None
            continue
        out[metric] = {"difference": float(d), "se": float(se), "df": float(df)}
    return out


def run_plan(
    plan: Plan, strata: Mapping[str, str], run: Source, out: Path, code: str
) -> list[dict[str, Any]]:
    """Run plan over the layouts of strata (layout -> its stratum) with episodes from run,
    logging to out (looks.jsonl, looks.md); returns the log's records: one per (family, cell,
    profile, look) read, {"family", "a", "b", "question", "profile", "look", "layouts",
    "difference", "se", "df", "level", "bound_difference", "bound_tost", "decision"}."""
    orders = [
        _family_order(plan, family, strata) for family in plan.families
    ]  # refused before plan.json
    check_resume(out, plan, code)
    atomic_write_text(
        out / ORDER_RECORD,
        json.dumps({f.name: order for f, order in zip(plan.families, orders, strict=True)}),
    )
    margin, records = plan.margins[plan.headline], []
    levels, passed = Levels(plan.multiplicity, plan.alpha, plan.cell_count), np.zeros(1, dtype=int)
    for family, order in zip(plan.families, orders, strict=True):
        bounds = LevelBounds(family.looks, family.maximum)
        open_cells = [(c, p) for c in plan.cells for p in plan.profiles]
        asked: set[Key] = set()
        for k, n in enumerate(family.looks):
            read = set(order[:n])
            for profile in plan.profiles:
                need = {m for c, p in open_cells if p == profile for m in c.sides}
                asked |= {(layout, profile, m) for layout in order[:n] for m in need}
            rows = [r for r in run(sorted(asked)) if r["world"] in read]
            by_profile = {p: [r for r in rows if r["noise"] == p] for p in plan.profiles}
            est = np.array([_read(plan, cell, profile, by_profile[profile])
                            for cell, profile in open_cells]).T[:, None, :]  # fmt: skip
            codes, passed, level = read_look(est[0], est[1], est[2], margin, np.ones(est.shape[1:], dtype=bool), passed,
                                             levels, bounds, k)  # fmt: skip
            bound_d, bound_t = bounds.look(level, k)
            still = []
            for i, ((cell, profile), got) in enumerate(
                zip(open_cells, codes[0].tolist(), strict=True)
            ):
                d, se, df = est[:, 0, i]
                if got == OPEN and k == len(family.looks) - 1:
                    got = INCONCLUSIVE
                side_a, side_b = cell.sides
                records.append({"family": family.name, "a": side_a, "b": side_b, "question": cell.question,
                                "profile": profile, "look": k + 1, "layouts": n, "difference": float(d),
                                "se": float(se), "df": float(df), "level": float(level[0, i]),
                                "bound_difference": float(bound_d[0, i]), "bound_tost": float(bound_t[0, i]),
                                "decision": DECISIONS[got],
                                "beside": _beside(plan, cell, profile, by_profile[profile])})  # fmt: skip
                if got == OPEN:
                    still.append((cell, profile))
            open_cells = still
            _write_log(out, records, plan)
            if not open_cells:
                break
    return records


def _write_log(out: Path, records: Sequence[Mapping[str, Any]], plan: Plan) -> None:
    atomic_write_text(out / LOOKS_LOG, "".join(json.dumps(r) + "\n" for r in records))
    body = [[r["family"], f"`{r['a']}` vs `{r['b']}`", r["profile"], str(r["look"]), str(r["layouts"]),
             f"{r['difference']:+.4f}", f"{r['se']:.4f}", f"{r['level']:.5g}", f"{r['bound_difference']:.3f}",
             f"{r['bound_tost']:.3f}", r["decision"]] for r in records]  # fmt: skip
    head = ["family", "A vs B", "profile", "look", "layouts", "A - B", "se", "level", "bound (difference)",
            "bound (TOST)", "decision"]  # fmt: skip
    table = split_columns(head, ["---"] * 4 + ["---:"] * 6 + ["---"], body, keys=3)
    title = (f"# Looks of {plan.name}\n\nHeadline {plan.headline}, margin {plan.margins[plan.headline]:g}; "
             f"multiplicity {plan.multiplicity} over {plan.cell_count} cells; bounds on z.\n\n")  # fmt: skip
    atomic_write_text(out / LOOKS_PAGE, title + table + "\n")
