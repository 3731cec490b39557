"""A sequential plan's answers: each cell's reading where it stopped, with its interval, per family.

``d3dwa sweep --plan`` logs every look of every cell (``looks.jsonl``, docs/design/sequential-plans.md).
This tool reads a plan run's directory and prints, per world family, each cell under each profile as it
stands: the decision, the look and layouts it stopped at, A - B on the headline metric with the
interval of the test that read it, and the other metrics the plan gives a margin beside it.

- **The headline's interval** is the repeated confidence interval of the plan's rule at the cell's
  last look: A - B +- se x t_df^-1(Phi(bound)), the bound on z of the test that read it (TOST's for an
  equivalent cell, so the interval lies inside +-margin; the difference's otherwise, so an A better
  interval lies above zero). It holds its level over the looks, as the readings do.
- **Beside** (success, BARN's score): the estimate on the same layouts with a plain 95 % t interval, a
  description that stopped nothing and reads nothing (a plan stops on its headline alone).

The plan file is required and must be the one the run began with (its sha256 in ``plan.json``): the
margins and the headline are its. A run still going prints its open cells as ``open``.

    python -m tools.experiments.plan_answers runs/recipes --plan docs/pilots/recipes/plan.yaml \\
        --figure docs/pilots/recipes/answers.png

**The cost** closes the page: per family, the episodes the run holds against the fixed design's (every
layout of the family's maximum, every run seen there under each profile: method, training seed and
evaluation seed), and their ratio.

``--json`` prints the records (and the cost); ``--figure PATH`` draws the headline's readings (one line per family and
cell, a marker per profile) against the margin (``readings_figure``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from scipy import stats

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.page_width import split_columns
from d3dwa_bullet.evaluation.plans.plan_file import Plan, load_plan
from d3dwa_bullet.evaluation.plans.run import LOOKS_LOG, ORDER_RECORD, PLAN_RECORD
from d3dwa_bullet.evaluation.plans.setting_sides import SETTING_DIR
from d3dwa_bullet.evaluation.sweep import read_sweep
from d3dwa_bullet.loading import load_json, load_json_lines
from tools.entry import ToolParser, tool_main
from tools.experiments import readings_figure

RESULTS = "results.csv"
"""A sweep directory's episodes."""
BESIDE_LEVEL = 0.95
"""The plain interval of a metric beside the headline."""


def half_width(se: float, df: float, z_bound: float) -> float:
    """The half-width of the t interval whose one-sided tail matches the normal bound z_bound."""
    return float(se * stats.t.ppf(stats.norm.cdf(z_bound), df))


def answers(plan: Plan, looks: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Each (family, cell, profile)'s last logged look as {family, a, b, profile, question, decision,
    look, layouts, difference, low, high, beside: {metric: {difference, low, high} or None}}, in the
    plan's order (families, then cells, then profiles)."""
    last = {(r["family"], r["a"], r["b"], r["profile"]): r for r in looks}
    out = []
    for family in plan.families:
        for cell in plan.cells:
            for profile in plan.profiles:
                a, b = cell.sides
                r = last.get((family.name, a, b, profile))
                if r is None:
                    continue
                bound = r["bound_tost"] if r["decision"] == "equivalent" else r["bound_difference"]
                h = half_width(r["se"], r["df"], bound)
                beside = {}
                for metric, e in (r.get("beside") or {}).items():
                    q = (
                        half_width(e["se"], e["df"], stats.norm.ppf(0.5 + BESIDE_LEVEL / 2))
                        if e
                        else 0.0
                    )
                    beside[metric] = e and {"difference": e["difference"], "low": e["difference"] - q,
                                            "high": e["difference"] + q}  # fmt: skip
                out.append({"family": family.name, "a": a, "b": b, "profile": profile,
                            "question": cell.question, "decision": r["decision"], "look": r["look"],
                            "layouts": r["layouts"], "difference": r["difference"],
                            "low": r["difference"] - h, "high": r["difference"] + h, "beside": beside})  # fmt: skip
    return out


def cost(plan: Plan, out: Path) -> list[dict[str, Any]]:
    """Per family {family, episodes, fixed, ratio}: the episodes out holds (in out, or in each
    setting's subdirectory of a plan across settings) against the fixed design's: under each
    profile, every run seen there (method, training seed, evaluation seed) on every layout of the
    family's maximum."""
    order = load_json(out / ORDER_RECORD, ResultsError)
    dirs = [d.parent for d in [out / RESULTS, *sorted(out.glob(f"{SETTING_DIR.format('*')}/{RESULTS}"))]
            if d.exists()]  # fmt: skip
    rows = [r for d in dirs for r in read_sweep(d)]
    out_rows = []
    for family in plan.families:
        layouts = set(order.get(family.name, ()))
        mine = [r for r in rows if r["world"] in layouts and r["noise"] in plan.profiles]
        units = {(str(r.get("global_plan") or ""), r["noise"], r["method"], r.get("policy_seed"), r["seed"])
                 for r in mine}  # fmt: skip
        fixed = len(units) * family.maximum
        out_rows.append({"family": family.name, "episodes": len(mine), "fixed": fixed,
                         "ratio": fixed / len(mine) if mine else None})  # fmt: skip
    return out_rows


def _interval(e: Mapping[str, float] | None, scale: float = 1.0) -> str:
    if not e:
        return "-"
    return f"{e['difference'] * scale:+.3f} [{e['low'] * scale:+.3f}, {e['high'] * scale:+.3f}]"


def markdown(plan: Plan, records: Sequence[Mapping[str, Any]]) -> str:
    """One table per family: cell, profile, decision, stop, A - B [interval], and the metrics beside."""
    others = [m for m in plan.margins if m != plan.headline]
    parts = []
    for family in plan.families:
        body = [[f"`{r['a']}` vs `{r['b']}`", r["profile"], r["decision"], f"{r['look']} ({r['layouts']})",
                 _interval(r)] + [_interval(r["beside"].get(m)) for m in others]
                for r in records if r["family"] == family.name]  # fmt: skip
        if not body:
            continue
        head = ["A vs B", "profile", "reading", "look (layouts)", f"{plan.headline} A - B"]
        head += [f"{m} A - B (beside)" for m in others]
        margins = ", ".join(f"{m} +-{v:g}" for m, v in plan.margins.items())
        parts.append(f"## {family.name}\n\nMargins {margins}; the reading is the {plan.headline}'s.\n\n"
                     + split_columns(head, ["---", "---", "---", "---:"] + ["---:"] * (1 + len(others)), body,
                                     keys=2))  # fmt: skip
    return f"# Answers of {plan.name}\n\n" + "\n\n".join(parts) + "\n"


def cost_markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """The cost table: per family the episodes run, the fixed design's, and fixed / run."""
    body = [[r["family"], f"{r['episodes']:,}", f"{r['fixed']:,}", f"{r['ratio']:.2f}x" if r["ratio"] else "-"]
            for r in rows]  # fmt: skip
    total = [sum(r[k] for r in rows) for k in ("episodes", "fixed")]
    body.append(
        [
            "all",
            f"{total[0]:,}",
            f"{total[1]:,}",
            f"{total[1] / total[0]:.2f}x" if total[0] else "-",
        ]
    )
    table = split_columns(
        ["family", "episodes run", "fixed design", "fixed / run"], ["---"] + ["---:"] * 3, body
    )
    return "## Cost\n\n" + table + "\n"


def figure(plan: Plan, records: Sequence[Mapping[str, Any]], path: Path) -> Path:
    """The headline's readings, one line per (family, cell), drawn by ``readings_figure``."""
    drawn = [{"a": f"{r['family']}: {r['a']}", "b": r["b"], "profile": r["profile"],
              "readings": {plan.headline: {"difference": r["difference"], "low": r["low"], "high": r["high"],
                                           "reading": r["decision"], "margin": plan.margins[plan.headline]}}}
             for r in records]  # fmt: skip
    label = f"{plan.headline}, A - B"
    return readings_figure.draw(drawn, path, f"{plan.name}: readings where each cell stopped",
                                panels=((plan.headline, label),))  # fmt: skip


def load_run(out: Path, plan_path: Path) -> tuple[Plan, list[dict[str, Any]]]:
    """The plan (checked against the one the run began with) and the run's looks."""
    plan = load_plan(plan_path)
    began = load_json(out / PLAN_RECORD, ResultsError)
    if not isinstance(began, dict) or began.get("sha256") != plan.digest:
        raise ConfigError(
            f"--plan {plan_path}: not the plan {out} ran (its sha256 differs from {PLAN_RECORD})"
        )
    return plan, load_json_lines(out / LOOKS_LOG, ResultsError)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "out", type=Path, help="the plan run's directory (d3dwa sweep --plan ... --out OUT)"
    )
    parser.add_argument("--plan", type=Path, required=True, help="the plan file the run began with")
    parser.add_argument("--json", action="store_true", help="print the records as JSON")
    parser.add_argument("--figure", type=Path, help="draw the headline's readings to this PNG")
    args = parser.parse_args(argv)
    plan, looks = load_run(args.out, args.plan)
    records, spent = answers(plan, looks), cost(plan, args.out)
    if args.figure:
        figure(plan, records, args.figure)
    if args.json:
        print(json.dumps({"cells": records, "cost": spent}, indent=1))
    else:
        print(markdown(plan, records) + "\n" + cost_markdown(spent))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
