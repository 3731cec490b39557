"""``d3dwa compare DIR --methods A,B``: the probability that A improves on B, with its interval.

P(A > B) (Agarwal et al., 2021) is the chance that a run of A reaches the goal more often
than a run of B on the same task (world and noise), ties counting half, averaged over the
tasks of a group; 0.5 is no difference. A learned method's runs are its training seeds, a
fixed or reference method's its evaluation seeds (:mod:`d3dwa_bullet.evaluation.seed_tables`). Groups:
the shipped world groups (train, unseen, real) of a ``d3dwa eval`` directory, or the layout
groups (shipped, generated) of a ``d3dwa sweep`` directory, each under its noise, then
every layout under each noise, then all tasks.

Beside each P(A > B), a test paired by layout: the one-sided Wilcoxon signed-rank p-value of
A > B over the (layout, noise, evaluation seed) both ran, each side's success there averaged
over its training seeds (:mod:`d3dwa_bullet.evaluation.paired`, docs/design.md#paired-test).
Two methods sharing fewer than two layouts are refused in one line. ``--methods A`` alone, A
a learned method, compares A with both its floors present in DIR (every step and held).

``--against DIR2`` takes B's runs from a second directory: the same method with and without
the recovery layer (``d3dwa compare rec --against norec --methods dwa3,dwa3``), whose runs
never share a directory. Each side is labelled with its recovery setting.
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
    p.add_argument(
        "--methods",
        required=True,
        help="A,B: two methods present in DIR; or a learned method A alone: A against both its "
        "floors (random@10 and random, or their weights-only twins)",
    )
    p.add_argument(
        "--against",
        metavar="DIR2",
        help="take B's runs from this results directory (e.g. the same method without the "
        "recovery layer); A and B may then be the same method",
    )
    p.add_argument(
        "--pair-by",
        choices=("layout-seed", "layout"),
        default="layout-seed",
        help="unit of the paired test: (layout, evaluation seed), the default, or the layout "
        "with each side averaged over its evaluation seeds (fewer units, not sharing a layout)",
    )
    p.add_argument("--json", action="store_true", help="print the records as JSON")
    p.set_defaults(func=cmd_compare)


def _groups_of(row: dict[str, Any], shipped: dict[str, str]) -> list[str]:
    noise = row["noise"]
    if "layout" in row:  # a sweep's row
        return [f"{row['layout']} ({noise})", f"all layouts ({noise})"]
    return [f"{shipped.get(row['world'], 'custom')} ({noise})", f"all worlds ({noise})"]


def _side(out: Path, method: str, warn: bool = True) -> tuple[list[dict[str, Any]], str, bool]:
    """(rows of method in results directory out, its recovery setting, complete?); one line
    naming what is wrong with the directory otherwise."""
    # start-up cost: SciPy's bootstrap (~0.5 s); no simulator, no torch
    from d3dwa_bullet.evaluation.results import completion, recovery_of
    from d3dwa_bullet.evaluation.seed_tables import check_not_mixed

    rows = job_rows_of(out)
    check_not_mixed(rows, str(out / "results.csv"))
    present = {r["method"] for r in rows}
    if method not in present:
        raise ResultsError(
            f"{out / 'results.csv'}: no rows of method {method!r} (it has {', '.join(sorted(present))})"
        )
    done, expected = completion(out, rows)
    if done != expected and warn:
        print(
            f"d3dwa: warning: {out} is incomplete ({done} of {expected} episodes); "
            "comparing the finished ones",
            file=sys.stderr,
        )
    return [r for r in rows if r["method"] == method], recovery_of(out), done == expected


def cmd_compare(args: argparse.Namespace) -> int:
    # start-up cost: a method from outside the package is resolved (its module imported)
    from d3dwa_bullet.evaluation.floors import floors_for
    from d3dwa_bullet.method_specs import check_method

    names = [m.strip() for m in args.methods.split(",") if m.strip()]
    # one learned or external method: against its floors (a velocity planner: DWA III)
    own = floors_for(check_method(names[0]))[0] if len(names) == 1 else ()
    if own and not args.against:
        out = Path(args.dir)
        rows = job_rows_of(out)
        present = {r["method"] for r in rows}
        floors = [f for f in own if f in present]
        if not floors:
            raise ResultsError(
                f"{out / 'results.csv'}: no floor of method {names[0]!r} "
                f"({', '.join(own)}) to compare it with"
            )
        for floor in floors:
            _compare(args, names[0], floor)
        return 0
    same = len(names) == 2 and names[0] == names[1]
    if len(names) != 2 or (same and not args.against):
        raise ConfigError(f"--methods needs two different methods A,B, got {args.methods!r}")
    a, b = (check_method(m) for m in names)
    _compare(args, a, b)
    return 0


def job_rows_of(out: Path) -> list[dict[str, Any]]:
    """The rows of results directory out (ResultsError if it is not one)."""
    # start-up cost: SciPy's bootstrap (~0.5 s); no simulator, no torch
    from d3dwa_bullet.evaluation.results import check_results_dir, job_rows

    if not (out / "results.csv").is_file():
        raise ResultsError(f"{out}: not a results directory (no results.csv)")
    check_results_dir(out)
    return job_rows(out)


def _compare(args: argparse.Namespace, a: str, b: str) -> None:
    # start-up cost: SciPy (~0.5 s), only for this command
    from d3dwa_bullet.evaluation.paired import (
        check_layouts,
        paired_by_group,
        paired_scores,
        unit_of,
    )
    from d3dwa_bullet.evaluation.seed_tables import improvement, improvement_table
    from d3dwa_bullet.method_specs import method_label
    from d3dwa_bullet.world.registry import world_groups

    same = a == b
    out = Path(args.dir)
    other = Path(args.against) if args.against else out
    rows_a, rec_a, complete_a = _side(out, a)
    rows_b, rec_b, complete_b = _side(other, b, warn=other != out)
    # one method on both sides: its runs are told apart by their directory's recovery
    key_a, key_b = (f"{a} [A]", f"{b} [B]") if same else (a, b)
    labels = {
        key_a: method_label(a) + (f" + recovery {rec_a}" if rec_a != "none" else ""),
        key_b: method_label(b) + (f" + recovery {rec_b}" if rec_b != "none" else ""),
    }
    if same and labels[key_a] == labels[key_b]:
        labels[key_a] += f" ({out})"
        labels[key_b] += f" ({other})"
    rows = [r | {"method": key_a} for r in rows_a] + [r | {"method": key_b} for r in rows_b]
    source = f"{out / 'results.csv'}" + (f" and {other / 'results.csv'}" if args.against else "")
    check_layouts(paired_scores(rows, key_a, key_b), a, b, source)
    shipped = world_groups()
    records = improvement(rows, key_a, key_b, lambda r: _groups_of(r, shipped))
    by_seed = args.pair_by == "layout-seed"
    group_of = {unit_of(r, by_seed): _groups_of(r, shipped) for r in rows}
    paired = paired_by_group(rows, key_a, key_b, group_of, by_seed)
    for record in records:
        test = paired.get(record["group"], {})
        record |= {f"paired_{k}": v for k, v in test.items()}
    if args.json:
        print(json_text({"results": str(out), "against": str(other), "a": a, "b": b,
                          "recovery_a": rec_a, "recovery_b": rec_b, "pair_by": args.pair_by,
                          "complete": complete_a and complete_b, "groups": records}))  # fmt: skip
        return
    la, lb = labels[key_a], labels[key_b]
    unit, pooled = (
        ("(layout, noise, evaluation seed)", "training seeds")
        if by_seed
        else ("(layout, noise)", "training and evaluation seeds")
    )
    print(
        f"P({la} > {lb}) on success per task (world, noise); 95 % stratified bootstrap "
        f"over runs; 0.5 = no difference. Paired by {unit}, each side's success averaged "
        f"over its {pooled}: A better / worse in how many pairs, and the one-sided Wilcoxon "
        f"signed-rank p-value of A > B. From {source}.\n"
    )
    print(improvement_table(records, key_a, key_b, labels), end="")
    seeds = {int(r["seed"]) for r in rows}
    if by_seed and len(seeds) > 1:
        print(
            f"\n{len(seeds)} evaluation seeds share each layout, so these pairs are not "
            "independent (without noise a fixed or greedy method repeats its episode at every "
            "seed): `--pair-by layout` is the conservative test (docs/design.md#paired-test)."
        )
