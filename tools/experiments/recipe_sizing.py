"""The cheapest (training seeds, layouts) that reads each cell about the recipe at 80 % power.

From a pilot's results directory, for each cell (``--plan NAME`` for a committed plan's cells,
or ``--pair A,B`` repeated), noise profile and world family (BARN's worlds; the R-style
generated layouts; ``other`` for any other world): the cell's variance components in the
metric (``--metric``, default the robot score) by the method of moments of
``evaluation.recipe_sizing`` (seed variance of each learned side, their residual, the layouts'
variance of the difference), and the cheapest design at 80 % power if the pilot's mean
difference were the truth: seeds a learned side, layouts, the aim (difference or equivalence
within the margin), its cost in hours. The costs are measured figures the user gives: a seed's
training minutes (``--train-minutes``) and an episode's wall seconds per family
(``--episode-seconds BARN=1.2 --episode-seconds R-style=0.41``, or one number for all).

    python -m tools.experiments.recipe_sizing docs/pilots/yardstick-barn/sweep --plan yardstick \\
        --train-minutes 8.83 --episode-seconds BARN=1.2 --episode-seconds R-style=0.41

A planning figure, not a test: commit it before the sweep it sizes (docs/design/readings-recipe.md).
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.margins import MARGINS, margin_text
from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.paired import METRICS
from d3dwa_bullet.evaluation.readings import metric_text
from d3dwa_bullet.evaluation.recipe import check_recipe_side, seed_layout_tables
from d3dwa_bullet.evaluation.recipe_sizing import cheapest, components
from d3dwa_bullet.evaluation.recipe_tables import FAMILIES, family_of
from tools.entry import ToolParser, tool_main
from tools.experiments.plan_readings import PLANS
from tools.experiments.power_plan import pilot_rows

OTHER = "other"
"""The family of a row neither BARN's nor a generated layout's (a shipped or given world)."""


def named_numbers(
    given: Sequence[str], option: str, default_key: str | None = None
) -> dict[str, float]:
    """'NAME=X' values (and, with default_key, one bare 'X' for every name) as {name: x};
    ConfigError naming the option and value for anything not a positive finite number."""
    out: dict[str, float] = {}
    for text in given:
        name, _, value = text.rpartition("=")
        try:
            x = float(value)
        except ValueError:
            x = math.nan
        if not (math.isfinite(x) and x > 0):
            raise ConfigError(f"{option} {text!r}: the number must be a positive finite number")
        if not name and default_key is None:
            raise ConfigError(f"{option} {text!r}: expected NAME=X")
        out[name or default_key or ""] = x
    return out


def episode_costs(given: Sequence[str]) -> dict[str, float]:
    """--episode-seconds values ('FAMILY=S' or one 'S' for every family) as {family: s};
    ConfigError naming a value that is not a positive finite number or a family unknown."""
    known = (*FAMILIES, OTHER)
    out: dict[str, float] = {}
    for family, seconds in named_numbers(given, "--episode-seconds", default_key="").items():
        if family and family not in known:
            raise ConfigError(
                f"--episode-seconds {family}={seconds:g}: unknown family (one of {', '.join(known)})"
            )
        for f in (family,) if family else known:
            out[f] = seconds
    return out


def size_cells(
    rows: Sequence[Mapping[str, Any]],
    pairs: Sequence[tuple[str, str]],
    metric: str,
    margin: float,
    train_minutes: float,
    costs: Mapping[str, float],
) -> list[dict[str, Any]]:
    """One record per (cell, profile, family): {"a", "b", "profile", "family", "layouts",
    "components": {...}, "design": cheapest(...)}. ResultsError naming a method the rows lack,
    a learned side with one training seed, or a family without an episode cost."""
    present = {r["method"] for r in rows}
    for m in dict.fromkeys(m for pair in pairs for m in pair):
        if m not in present:
            raise ResultsError(f"no rows of method {m!r} (present: {', '.join(sorted(present))})")
        check_recipe_side(rows, m)
    by: dict[tuple[str, str, str], list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        by[(r["noise"], r["method"], family_of(r) or OTHER)].append(r)
    profiles = list(dict.fromkeys(r["noise"] for r in rows))
    out = []
    for a, b in pairs:
        for profile in profiles:
            for family in (*FAMILIES, OTHER):
                here = [*by.get((profile, a, family), ()), *by.get((profile, b, family), ())]
                ta, tb, layouts = seed_layout_tables(here, a, b, metric)
                if len(layouts) < 2:
                    continue
                if family not in costs:
                    raise ConfigError(
                        f"--episode-seconds: no cost for family {family!r}, which the rows hold"
                    )
                c = components(ta, tb)
                design = cheapest(c, margin, train_minutes, costs[family])
                out.append({"a": a, "b": b, "profile": profile, "family": family, "layouts": len(layouts),
                            "seeds_now": [ta.shape[0], tb.shape[0]], "components": c.as_dict(),
                            "design": design})  # fmt: skip
    return out


def table(records: Sequence[Mapping[str, Any]], metric: str, margin: float) -> str:
    """The records as Markdown: a line per (cell, profile, family)."""
    head = ["A vs B", "profile", "family", "A - B", "aim", "seeds", "layouts", "hours",
            "seed var A", "seed var B", "resid A", "resid B", "layout var"]  # fmt: skip
    align = [*["---"] * 3, "---:", "---", *["---:"] * 8]
    body = []
    for r in records:
        c, d = r["components"], r["design"]
        var = [f"{c[k]:.2g}" for k in ("seed_a", "seed_b", "resid_a", "resid_b", "layout")]
        plan = ([d["aim"], str(d["seeds"] or "--"), f"{d['layouts']:,}", f"{d['hours']:.1f}"]
                if "aim" in d else ["none in reach", "--", "--", "--"])  # fmt: skip
        diff = metric_text(metric, c["difference"], signed=True)
        body.append([f"`{r['a']}` vs `{r['b']}`", r["profile"], r["family"], diff, *plan, *var])
    title = (f"The cheapest design per cell at 80 % power, the recipe's reading of {metric} (margin "
             f"{margin_text(metric, margin)}); seeds a learned side, variances in the metric's units "
             "squared; none in reach: no design within 50 seeds and 100,000 layouts reaches 80 % power.\n")  # fmt: skip
    return fit_prose(title) + "\n" + split_columns(head, align, body, keys=3)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="recipe_sizing", description=__doc__.split("\n")[0])
    parser.add_argument("pilot", type=Path, help="a pilot's results directory")
    parser.add_argument("--plan", choices=sorted(PLANS), help="a committed plan's cells")
    parser.add_argument(
        "--pair", action="append", default=[], metavar="A,B", help="a cell (repeatable)"
    )
    parser.add_argument("--metric", choices=METRICS, default="score")
    parser.add_argument(
        "--margin", type=float, help="the metric's margin in its units (default: plan's or 0.03)"
    )
    parser.add_argument(
        "--train-minutes", type=float, required=True, help="a seed's training, wall minutes"
    )
    parser.add_argument("--episode-seconds", action="append", required=True, metavar="[FAMILY=]S",
                        help="an episode's wall seconds, per family or for all (repeatable)")  # fmt: skip
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if bool(args.plan) == bool(args.pair):
        parser.error("give either --plan or --pair")
    if not (math.isfinite(args.train_minutes) and args.train_minutes > 0):
        parser.error(
            f"--train-minutes must be a positive finite number, got {args.train_minutes:g}"
        )
    if args.margin is not None and not (math.isfinite(args.margin) and args.margin > 0):
        parser.error(f"--margin must be a positive finite number, got {args.margin:g}")
    costs = episode_costs(args.episode_seconds)
    if args.plan:
        pairs, margins = list(PLANS[args.plan].pairs), PLANS[args.plan].margins
    else:
        pairs, margins = [], MARGINS
        for text in args.pair:
            names = [m.strip() for m in text.split(",")]
            if len(names) != 2 or not all(names) or names[0] == names[1]:
                parser.error(f"--pair needs two different methods A,B, got {text!r}")
            pairs.append((names[0], names[1]))
    margin = args.margin if args.margin is not None else margins[args.metric]
    records = size_cells(
        pilot_rows([args.pilot]), pairs, args.metric, margin, args.train_minutes, costs
    )
    print(
        json.dumps(records, indent=1) if args.json else table(records, args.metric, margin), end=""
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
