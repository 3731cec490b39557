"""``d3dwa compare DIR --methods A,B``: the probability that A improves on B, with its interval.

P(A > B) (Agarwal et al., 2021) is the chance that a run of A reaches the goal more often
than a run of B on the same task (world and noise), ties counting half, averaged over the
tasks of a group; 0.5 is no difference. A learned method's runs are its training seeds, a
fixed method's its evaluation seeds (:mod:`d3dwa_bullet.evaluation.seed_tables`). Groups:
the shipped world groups (train, unseen, real) of a ``d3dwa eval`` directory, or the layout
groups (shipped, generated) of a ``d3dwa sweep`` directory, each under its noise, then
every layout under each noise, then all tasks.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.errors import ConfigError, ResultsError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare", help="P(A improves on B) over training seeds, per world group and overall"
    )
    p.add_argument("dir", help="a results directory of `d3dwa eval` or `d3dwa sweep`")
    p.add_argument("--methods", required=True, help="A,B: two methods present in DIR")
    p.add_argument("--json", action="store_true", help="print the records as JSON")
    p.set_defaults(func=cmd_compare)


def _groups_of(row: dict[str, Any], shipped: dict[str, str]) -> list[str]:
    noise = row["noise"]
    if "layout" in row:  # a sweep's row
        return [f"{row['layout']} ({noise})", f"all layouts ({noise})"]
    return [f"{shipped.get(row['world'], 'custom')} ({noise})", f"all worlds ({noise})"]


def cmd_compare(args: argparse.Namespace) -> int:
    # start-up cost: SciPy's bootstrap (~0.5 s); no simulator, no torch
    from d3dwa_bullet.evaluation.results import check_results_dir, completion, job_rows
    from d3dwa_bullet.evaluation.seed_tables import (
        check_not_mixed,
        improvement,
        improvement_table,
    )
    from d3dwa_bullet.methods import LABELS, check_method
    from d3dwa_bullet.world.registry import world_groups

    names = [m.strip() for m in args.methods.split(",") if m.strip()]
    if len(names) != 2 or names[0] == names[1]:
        raise ConfigError(f"--methods needs two different methods A,B, got {args.methods!r}")
    a, b = (check_method(m) for m in names)
    out = Path(args.dir)
    if not (out / "results.csv").is_file():
        raise ResultsError(f"{out}: not a results directory (no results.csv)")
    check_results_dir(out)
    rows = job_rows(out)
    check_not_mixed(rows, str(out / "results.csv"))
    present = {r["method"] for r in rows}
    for m in (a, b):
        if m not in present:
            raise ResultsError(
                f"{out / 'results.csv'}: no rows of method {m!r} (it has {', '.join(sorted(present))})"
            )
    done, expected = completion(out, rows)
    if done != expected:
        print(
            f"d3dwa: warning: {out} is incomplete ({done} of {expected} episodes); "
            "comparing the finished ones",
            file=sys.stderr,
        )
    shipped = world_groups()
    records = improvement(rows, a, b, lambda r: _groups_of(r, shipped))
    if args.json:
        print(json_text({"results": str(out), "a": a, "b": b, "complete": done == expected,
                          "groups": records}))  # fmt: skip
    else:
        la, lb = LABELS.get(a, a), LABELS.get(b, b)
        print(
            f"P({la} > {lb}) on success per task (world, noise); 95 % stratified bootstrap "
            f"over runs; 0.5 = no difference. From {out / 'results.csv'}.\n"
        )
        print(improvement_table(records, a, b), end="")
    return 0
