"""Each method's success, robot score and BARN's official score under each profile of a results
directory, layout by layout: a method's episodes on a layout (its training and evaluation seeds)
averaged first, then the layouts. The table docs/results.md gives beside a plan's readings.

    python -m tools.experiments.method_means runs/barn-trained/challenge
    python -m tools.experiments.method_means runs/barn-trained/r-style --json

A cell reads ``success %, robot score (BARN's score)``; "--" where the method has no episode
under that profile, or a row of it lacks the score (results from before the score). The first
line says how many of the directory's listed episodes are in: a partial directory's means are
a progress report, not a reading.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from statistics import fmean
from typing import Any

from d3dwa_bullet.cli.compare import job_rows_of
from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.paired import metric_value
from d3dwa_bullet.evaluation.readings import metric_text
from d3dwa_bullet.evaluation.results import completion
from tools.entry import ToolParser, tool_main

METRICS = ("success", "score", "score_barn")
"""The metrics of a cell, in its order."""


def method_means(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, dict[str, Any]]]:
    """{method: {profile: {"layouts": n, metric: mean over layouts or None}}}, methods and
    profiles in the rows' order; a metric is None when a row of that cell lacks it."""
    per: dict[tuple[str, str], dict[str, list[Mapping[str, Any]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    for r in rows:
        per[(r["method"], r["noise"])][r["world"]].append(r)
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for (method, profile), layouts in per.items():
        cell: dict[str, Any] = {"layouts": len(layouts)}
        for metric in METRICS:
            values = [[metric_value(r, metric) for r in rs] for rs in layouts.values()]
            if any(v is None for vs in values for v in vs):
                cell[metric] = None
            else:
                cell[metric] = fmean(fmean(v for v in vs if v is not None) for vs in values)
        out.setdefault(method, {})[profile] = cell
    return out


def _cell(cell: Mapping[str, Any] | None) -> str:
    if cell is None:
        return "--"
    success = metric_text("success", cell["success"])
    if cell["score"] is None:
        return success
    barn = (
        "" if cell["score_barn"] is None else f" ({metric_text('score_barn', cell['score_barn'])})"
    )
    return f"{success}, {metric_text('score', cell['score'])}{barn}"


def markdown(means: Mapping[str, Mapping[str, Mapping[str, Any]]], done: int, listed: int) -> str:
    """The table, a line per method and a column per profile, under a line on completion."""
    profiles = list(dict.fromkeys(p for per in means.values() for p in per))
    layouts = sorted({c["layouts"] for per in means.values() for c in per.values()})
    body = [[f"`{m}`", *(_cell(per.get(p)) for p in profiles)] for m, per in means.items()]
    table = split_columns(["method", *profiles], ["---"] + ["---:"] * len(profiles), body)
    counted = (
        " to ".join(dict.fromkeys(str(n) for n in (layouts[0], layouts[-1]))) if layouts else "0"
    )
    head = (f"{done:,} of {listed:,} listed episodes in; {counted} layouts a cell. Success [%], "
            "mean robot score and (in brackets) BARN's official score, a method's seeds averaged "
            "within a layout.")  # fmt: skip
    return f"{fit_prose(head)}\n\n{table}"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="method_means", description=__doc__.split("\n")[0])
    parser.add_argument("results", type=Path, help="a results directory (eval or sweep)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = job_rows_of(args.results)
    done, listed = completion(args.results, rows)
    means = method_means(rows)
    if args.json:
        print(json.dumps({"episodes": done, "listed": listed, "means": means}, indent=1))
    else:
        print(markdown(means, done, listed), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
