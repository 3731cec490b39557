"""The retro-check of a sequential plan: a finished fixed-N sweep replayed through the rule.

Given a finished results directory and a committed plan file (d3dwa_bullet.evaluation.plans),
the layouts are put in the plan's order (its ``order_seed``; strata interleaved), and each cell
under each profile is read at each look on the headline metric against the plan's
Lan-DeMets O'Brien-Fleming boundaries for the t (``student.rule_boundaries``), stopping once it
reads (docs/design/sequential-plans.md).
A method under a profile runs on a look's layouts while some open cell of that profile names it;
the episodes it would have needed are the rows it has on those layouts. Printed: each cell's
sequential reading in the committed order beside the fixed-N reading (``plan_readings``' rule on
every layout), whether they agree, and over ``--orders`` further orders (seeds order_seed + 1,
...) the spread of the episodes needed and of each cell's agreement.

    python -m tools.experiments.sequential_retro docs/pilots/yardstick-barn/sweep \\
        --plan docs/pilots/yardstick-barn/sequential-retro.yaml --orders 200

Only the ``policies`` question replays here (each side averaged over its seeds on a layout, the
fixed-N reading's question); a ``recipe`` cell is refused until its estimator is wired, and so are
a cell across global-plan settings (one directory holds one setting) and a plan naming a
multiplicity control (each cell replays at the plan's alpha). A plan's ``seeds`` keep each listed
method to its N lowest training seeds in the rows (``plan_seeds.plan_seed_rows``).
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.margins import margin_text
from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.paired import paired_scores
from d3dwa_bullet.evaluation.plans import (
    DECISIONS,
    Family,
    Plan,
    decisions,
    first_reading,
    layout_order,
    load_plan,
    prefix_estimates,
)
from d3dwa_bullet.evaluation.plans.order import stratum_of
from d3dwa_bullet.evaluation.plans.plan_seeds import plan_seed_rows
from d3dwa_bullet.evaluation.plans.student import rule_boundaries
from d3dwa_bullet.evaluation.readings import metric_text
from tools.entry import ToolParser, tool_main
from tools.experiments.plan_readings import finished_rows, read_cells

Rows = Sequence[Mapping[str, Any]]


def family_layouts(rows: Rows, family: Family) -> dict[str, list[str]]:
    """{stratum: its layouts} of a family, in the plan's strata order; ResultsError when a
    stratum has none or the family's maximum is not the layouts the rows hold."""
    found: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        found[str(stratum_of(r))].add(r["world"])
    out = {s: sorted(found.get(s, ())) for s in family.strata}
    empty = [s for s, layouts in out.items() if not layouts]
    if empty:
        raise ResultsError(f"family {family.name}: no layouts of stratum {empty[0]!r} in the rows")
    total = sum(map(len, out.values()))
    if total != family.maximum:
        raise ResultsError(
            f"family {family.name}: maximum {family.maximum}, but the rows hold {total} layouts of its strata"
        )
    return out


def replay(rows: Rows, plan: Plan, orders: int) -> dict[str, Any]:
    """The sequential rule on rows, in the plan's order and in ``orders`` more: {"cells": one
    record per (family, cell, profile), "episodes": the episodes each order needed (the
    committed order first), "fixed_episodes": the rows of the plan's methods}."""
    bad = [c for c in plan.cells if c.question != "policies"]
    if bad:
        raise ConfigError(
            f"cell {bad[0].a},{bad[0].b}: question {bad[0].question!r} does not replay here "
            "(only 'policies': its estimator is not wired)"
        )
    across = [c for c in plan.cells if c.global_plan]
    if across:  # one results directory holds one --global-plan setting: both sides would be its
        raise ConfigError(
            f"cell {across[0].a},{across[0].b}: global_plan {list(across[0].global_plan or ())} reads "
            "across settings, which one results directory does not hold (run it with d3dwa sweep --plan)"
        )
    rows = plan_seed_rows(rows, plan)  # a plan with seeds reads its methods' lowest N only
    if plan.multiplicity != "none":
        raise ConfigError(
            f"multiplicity {plan.multiplicity}: the retro-check replays each cell at alpha (none) only"
        )
    metric, margin = plan.headline, plan.margins[plan.headline]
    count: dict[tuple[str, str, str], int] = defaultdict(int)  # (method, profile, world) -> rows
    for r in rows:
        count[(r["method"], r["noise"], r["world"])] += 1
    fixed = {(r["a"], r["b"], r["profile"]): r["readings"][metric]
             for r in read_cells(rows, [(c.a, c.b) for c in plan.cells], {metric: margin})}  # fmt: skip
    cells, episodes = [], np.zeros(orders + 1)
    for family in plan.families:
        strata = family_layouts(rows, family)
        seeds = [plan.order_seed + i for i in range(orders + 1)]
        index = {w: i for i, w in enumerate(sorted(w for ws in strata.values() for w in ws))}
        perms = np.array(
            [[index[w] for w in layout_order(strata, s)] for s in seeds]
        )  # (orders+1, n)
        looks = np.asarray(family.looks)
        bound_d, bound_t = rule_boundaries(looks, family.maximum, plan.alpha)
        stop: dict[tuple[str, str], np.ndarray] = {}  # (method, profile) -> the last look it ran to
        for profile in plan.profiles:
            here = [r for r in rows if r["noise"] == profile]
            for c in plan.cells:
                scores = paired_scores(here, c.a, c.b, by_seed=False, metric=metric)
                d = np.full(len(index), np.nan)
                for (world, _, _), (sa, sb) in scores.items():
                    if world in index:
                        d[index[world]] = sa - sb
                if np.isnan(d).any():
                    raise ResultsError(
                        f"cell {c.a},{c.b} under {profile}: a layout lacks a {metric}"
                    )
                diff, se, df = prefix_estimates(d[perms], looks)
                code, look = first_reading(decisions(diff, se, df, margin, bound_d, bound_t))
                for m in (c.a, c.b):
                    stop[(m, profile)] = np.maximum(stop.get((m, profile), look * 0), look)
                at = np.arange(len(seeds))
                cells.append({"family": family.name, "a": c.a, "b": c.b, "profile": profile,
                              "fixed": fixed.get((c.a, c.b, profile)), "codes": code, "looks": look,
                              "layouts": looks[look], "difference": diff[at, look]})  # fmt: skip
        order_of = {w: i for w, i in index.items()}
        worlds = sorted(order_of, key=order_of.__getitem__)
        for (method, profile), last in stop.items():
            per = np.array([count[(method, profile, w)] for w in worlds])[perms]
            episodes += np.cumsum(per, axis=1)[np.arange(len(seeds)), looks[last] - 1]
    methods = set(plan.methods)
    total = sum(n for (m, p, _), n in count.items() if m in methods and p in plan.profiles)
    return {"cells": cells, "episodes": episodes, "fixed_episodes": total}


def _fixed_text(record: Mapping[str, Any] | None, metric: str) -> str:
    if record is None or record.get("reading") is None:
        return "--"
    return f"{record['reading']} {metric_text(metric, record['difference'], signed=True)}"


def page(result: Mapping[str, Any], plan: Plan, command: str) -> str:
    """The retro-check as Markdown: the committed order's cells beside the fixed-N readings,
    then the spread over the other orders."""
    metric, cells, orders = plan.headline, result["cells"], len(result["episodes"]) - 1
    fixed_n, ep = result["fixed_episodes"], result["episodes"]
    body, agree_now, agree_rates = [], 0, []
    for c in cells:
        fixed = c["fixed"]["reading"] if c["fixed"] else None
        ok = np.array([DECISIONS[int(x)] == fixed for x in c["codes"]])
        agree_now += bool(ok[0])
        agree_rates.append(ok[1:].mean() if orders else np.nan)
        spread = (
            f"{100 * ok[1:].mean():.0f} % ({int(np.median(c['layouts'][1:]))})" if orders else "--"
        )
        body.append([f"`{c['a']}` vs `{c['b']}`", c["profile"], _fixed_text(c["fixed"], metric),
                     f"{DECISIONS[int(c['codes'][0])]} {metric_text(metric, float(c['difference'][0]), True)}",
                     str(int(c["layouts"][0])), "yes" if ok[0] else "**no**", spread])  # fmt: skip
    head = [
        "A vs B",
        "profile",
        "fixed N (2,550)",
        "sequential",
        "layouts",
        "agree",
        f"agree over {orders} orders (median layouts)",
    ]
    table = split_columns(head, ["---", "---", "---", "---", "---:", "---", "---:"], body, keys=2)
    lo, hi = (np.percentile(ep[1:], q) for q in (2.5, 97.5)) if orders else (np.nan, np.nan)
    lines = [
        "# Sequential retro-check",
        "",
        fit_prose(f"Plan: {plan.name} (sha256 {plan.digest[:12]}). Printed by:"),
        "",
        "```bash",
        command,
        "```",
        "",
        fit_prose(
            f"Headline metric {metric} (margin {margin_text(metric, plan.margins[metric])}); "
            f"alpha {plan.alpha:g}, {plan.spending} spending, looks at "
            + "; ".join(f"{f.name}: {', '.join(map(str, f.looks))} layouts" for f in plan.families)
            + f"; the order's seed {plan.order_seed}. The fixed-N reading is plan_readings' rule on "
            "every layout; a cell's sequential reading is taken at the look it stopped at, with A - B "
            "there and the layouts read. The last column: the share of the other orders whose "
            "reading agrees, and the median layouts they read."
        ),
        "",
        f"**Episodes.** Fixed N: {fixed_n:,}. Sequential, committed order: {int(ep[0]):,} "
        f"({fixed_n / ep[0]:.2f}x fewer).",
    ]
    if orders:
        lines.append(fit_prose(
            f"Over {orders} further orders (seeds {plan.order_seed + 1} .. {plan.order_seed + orders}): median "
            f"{int(np.median(ep[1:])):,}, 95 % of orders in [{int(lo):,}, {int(hi):,}], range "
            f"[{int(ep[1:].min()):,}, {int(ep[1:].max()):,}] ({fixed_n / ep[1:].max():.2f}x to "
            f"{fixed_n / ep[1:].min():.2f}x fewer)."
        ))  # fmt: skip
    lines += [
        "",
        f"**Agreement with the fixed-N reading.** Committed order: {agree_now} of {len(cells)} cells."
        + (
            f" Over the {orders} orders: {100 * np.nanmean(agree_rates):.1f} % of cell readings."
            if orders
            else ""
        ),
        "",
        table,
    ]
    off = [
        c
        for c in cells
        if not (c["fixed"] and DECISIONS[int(c["codes"][0])] == c["fixed"]["reading"])
    ]
    if off:
        named = "; ".join(
            f"`{c['a']}` vs `{c['b']}` under {c['profile']}: fixed N {_fixed_text(c['fixed'], metric)}, "
            f"sequential {DECISIONS[int(c['codes'][0])]} at {int(c['layouts'][0])} layouts"
            for c in off
        )
        lines += ["", fit_prose(f"Where the committed order disagrees: {named}.")]
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="sequential_retro", description=__doc__.split("\n")[0])
    parser.add_argument("results", type=Path, help="a finished sweep's results directory")
    parser.add_argument("--plan", type=Path, required=True, help="the committed plan file (YAML)")
    parser.add_argument(
        "--orders", type=int, default=200, help="further orders for the spread (default 200)"
    )
    parser.add_argument("--json", action="store_true", help="the figures as JSON")
    args = parser.parse_args(argv)
    if not 0 <= args.orders <= 10_000:
        parser.error(f"--orders must be between 0 and 10000, got {args.orders}")
    plan = load_plan(args.plan)
    result = replay(finished_rows(args.results), plan, args.orders)
    if args.json:
        out = {"fixed_episodes": result["fixed_episodes"], "episodes": result["episodes"].tolist(),
               "cells": [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in c.items()}
                         for c in result["cells"]]}  # fmt: skip
        print(json.dumps(out, indent=1, default=str))
        return 0
    command = (f"python -m tools.experiments.sequential_retro {args.results} \\\n"
               f"  --plan {args.plan} --orders {args.orders}")  # fmt: skip
    print(page(result, plan, command), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
