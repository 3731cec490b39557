"""A whole plan's budget: each recipe cell's power at a design, its fixed and sequential cost.

``recipe_sizing`` sizes one cell alone. A plan shares its training seeds between cells and
families, and reads many cells under one multiplicity control; this tool prices the whole:
for given training seeds per learned method (``--seeds METHOD=N``), layouts per family at the
last look (``--layouts FAMILY=N``) and looks (``--looks K``, equally spaced), each cell's
power at the level it starts at (``alpha / cells``: Holm's first level and Bonferroni's only
one, so a planning floor; Holm's recycling raises later levels), from a pilot's variance
components (``evaluation.recipe_sizing``), for its cheaper aim (difference or equivalence
within the margin). Then the cost: training (new seeds x a seed's minutes) and episodes,
once for the fixed design (every layout, every run, every profile) and once as the
sequential rule's expectation (a method runs on a family under a profile until no cell of it
is open there; a cell stops at the look its z first crosses the Lan-DeMets O'Brien-Fleming
bound, drawn from the crossing chances of the normal approximation, cells independent).

    python -m tools.experiments.recipe_budget docs/pilots/yardstick-barn/sweep --plan recipes \\
        --seeds d3dwa-weights=10 --seeds d3dwa=15 --seeds d3dwa-dr=15 --shipped 5 \\
        --layouts R-style=400 --layouts BARN=300 --looks 4 --train-minutes 9 --train-minutes d3dwa-dr=12 \\
        --episode-seconds BARN=1.2 --episode-seconds R-style=0.41

A planning figure, not a test: commit it before the plan it prices (docs/design/readings-recipe.md).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.plans.boundaries import boundaries, crossing_probability
from d3dwa_bullet.evaluation.readings import ALPHA
from d3dwa_bullet.evaluation.recipe_sizing import Components, design_se_df, power
from d3dwa_bullet.evaluation.recipe_tables import FAMILIES
from tools.entry import ToolParser, tool_main
from tools.experiments.plan_readings import PLANS
from tools.experiments.power_plan import pilot_rows
from tools.experiments.recipe_sizing import episode_costs, named_numbers, size_cells

DRAWS = 4000
"""Monte Carlo draws of the cells' stopping looks for the sequential expectation."""


def stop_chances(
    c: Components, seeds: int, layouts: int, looks: int, margin: float, alpha: float
) -> np.ndarray:
    """(looks + 1,) the chance the cell reads first at each look, then of staying open, by the
    normal approximation of its cheaper aim: a difference (one-sided alpha / 2 toward the
    pilot's sign) or equivalence (the nearer TOST bound at alpha)."""
    fractions = np.arange(1, looks + 1) / looks
    se, _ = design_se_df(c, seeds, layouts)
    if not se > 0:
        return np.r_[np.zeros(looks - 1), 1.0, 0.0]
    delta = abs(c.difference)
    aim_diff = power(c, seeds, layouts, "difference", margin, alpha)
    aim_equiv = power(c, seeds, layouts, "equivalence", margin, alpha)
    if aim_diff >= aim_equiv:
        p = crossing_probability(boundaries(fractions, alpha / 2), fractions, delta / float(se))
    else:
        p = crossing_probability(
            boundaries(fractions, alpha), fractions, (margin - delta) / float(se)
        )
    p = np.clip(p, 0.0, 1.0)
    return np.r_[p, max(0.0, 1.0 - p.sum())]


def budget(
    records: Sequence[Mapping[str, Any]], seeds: Mapping[str, int], layouts: Mapping[str, int],
    looks: int, margin: float, alpha: float, fixed: Sequence[str], seed: int = 0,
) -> dict[str, Any]:  # fmt: skip
    """Per cell {a, b, profile, family, power, aim}; per (family, profile) the fixed and the
    expected sequential episodes of each method; cells = len(records) sets the level."""
    level = alpha / len(records)
    rng = np.random.default_rng(seed)
    cells, stops = [], {}
    for r in records:
        c = Components(**r["components"])
        s = min(int(seeds[m]) for m in (r["a"], r["b"]) if m in seeds)
        n = int(layouts[r["family"]])
        pd, pe = (power(c, s, n, aim, margin, level) for aim in ("difference", "equivalence"))
        chances = stop_chances(c, s, n, looks, margin, level)
        look = rng.choice(looks + 1, size=DRAWS, p=chances / chances.sum())
        stops[(r["a"], r["b"], r["profile"], r["family"])] = np.minimum(look + 1, looks) * n / looks
        cells.append({"a": r["a"], "b": r["b"], "profile": r["profile"], "family": r["family"],
                      "difference": c.difference, "seeds": s, "layouts": n,
                      "aim": "difference" if pd >= pe else "equivalence", "power": max(pd, pe),
                      "read_by_look": np.cumsum(chances[:-1]).tolist()})  # fmt: skip
    runs: dict[tuple[str, str], dict[str, tuple[float, float]]] = {}
    methods = sorted({m for r in records for m in (r["a"], r["b"])})
    for family in {r["family"] for r in records}:
        for profile in {r["profile"] for r in records}:
            here: dict[str, tuple[float, float]] = {}
            for m in methods:
                mine = [
                    v
                    for (a, b, p, f), v in stops.items()
                    if f == family and p == profile and m in (a, b)
                ]
                if mine:
                    n_runs = int(seeds.get(m, 1)) if m not in fixed else 1
                    here[m] = (
                        float(layouts[family] * n_runs),
                        float(np.max(mine, axis=0).mean()) * n_runs,
                    )
            runs[(family, profile)] = here
    return {"level": level, "cells": cells, "episodes": runs}


def cost_hours(
    runs: Mapping[tuple[str, str], Mapping[str, tuple[float, float]]], episode_seconds: Mapping[str, float],
    new_seeds: Mapping[str, int], train_minutes: Mapping[str, float],
) -> dict[str, float]:  # fmt: skip
    """{training, fixed_episodes, sequential_episodes} in hours of both cores."""
    train = sum(n * train_minutes.get(m, train_minutes[""]) for m, n in new_seeds.items()) / 60
    fixed = (
        sum(v[0] * episode_seconds[f] for (f, _), here in runs.items() for v in here.values())
        / 3600
    )
    seq = (
        sum(v[1] * episode_seconds[f] for (f, _), here in runs.items() for v in here.values())
        / 3600
    )
    return {"training": train, "fixed_episodes": fixed, "sequential_episodes": seq}


def table(result: Mapping[str, Any], hours: Mapping[str, float]) -> str:
    head = [
        "A vs B",
        "profile",
        "family",
        "A - B",
        "aim",
        "seeds",
        "layouts",
        "power",
        "read by look",
    ]
    align = [*["---"] * 3, "---:", "---", *["---:"] * 4]
    body = [[f"`{c['a']}` vs `{c['b']}`", c["profile"], c["family"], f"{c['difference']:+.3f}", c["aim"],
             str(c["seeds"]), f"{c['layouts']:,}", f"{c['power']:.2f}",
             " ".join(f"{x:.2f}" for x in c["read_by_look"])] for c in result["cells"]]  # fmt: skip
    powered = sum(c["power"] >= 0.8 for c in result["cells"])
    lines = [
        f"Each cell at level {result['level']:.5f} (alpha / {len(result['cells'])} cells); "
        f"{powered} of {len(result['cells'])} cells at 80 % power or more.",
        f"Cost, hours of both cores: training {hours['training']:.1f}; episodes of the fixed design "
        f"{hours['fixed_episodes']:.1f} (total {hours['training'] + hours['fixed_episodes']:.1f}); "
        f"the sequential rule's expected episodes {hours['sequential_episodes']:.1f} "
        f"(total {hours['training'] + hours['sequential_episodes']:.1f}).",
        "",
    ]
    return fit_prose(" ".join(lines[:2])) + "\n\n" + split_columns(head, align, body, keys=3)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="recipe_budget", description=__doc__.split("\n")[0])
    parser.add_argument(
        "pilot", type=Path, nargs="+", help="pilot results directories (families apart)"
    )
    parser.add_argument(
        "--plan", choices=sorted(PLANS), required=True, help="a committed plan's cells"
    )
    parser.add_argument("--seeds", action="append", required=True, metavar="METHOD=N")
    parser.add_argument(
        "--shipped", type=int, default=5, help="seeds each learned method has already"
    )
    parser.add_argument("--layouts", action="append", required=True, metavar="FAMILY=N")
    parser.add_argument("--looks", type=int, default=4)
    parser.add_argument("--train-minutes", action="append", required=True, metavar="[METHOD=]M")
    parser.add_argument("--episode-seconds", action="append", required=True, metavar="[FAMILY=]S")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if args.looks < 1:
        parser.error(f"--looks must be >= 1, got {args.looks}")
    seeds = {m: int(n) for m, n in named_numbers(args.seeds, "--seeds").items()}
    layouts = {f: int(n) for f, n in named_numbers(args.layouts, "--layouts").items()}
    for family in layouts:
        if family not in FAMILIES:
            parser.error(f"--layouts {family!r}: unknown family (one of {', '.join(FAMILIES)})")
    train = named_numbers(args.train_minutes, "--train-minutes", default_key="")
    if "" not in train:
        parser.error("--train-minutes needs one bare value (the default for every method)")
    costs = episode_costs(args.episode_seconds)
    plan = PLANS[args.plan]
    margin = plan.margins["score"]
    records = []
    for pilot in args.pilot:
        records += size_cells(pilot_rows([pilot]), list(plan.pairs), "score", margin, 1.0, costs)
    records = [r for r in records if r["family"] in layouts]
    fixed = [m for m in {m for p in plan.pairs for m in p} if m not in seeds]
    result = budget(records, seeds, layouts, args.looks, margin, ALPHA, fixed)
    new = {m: max(0, n - args.shipped) for m, n in seeds.items()}
    hours = cost_hours(result["episodes"], costs, new, train)
    if args.json:
        out = {"level": result["level"], "cells": result["cells"], "hours": hours}
        print(json.dumps(out, indent=1))
    else:
        print(table(result, hours))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
