"""``d3dwa compare DIR --methods A,B``: the probability that A improves on B, with its interval.

P(A > B) (Agarwal et al., 2021) is the chance that a run of A reaches the goal more often
than a run of B on the same task (world and noise), ties counting half, averaged over the
tasks of a group; 0.5 is no difference. A learned method's runs are its training seeds, a
fixed or reference method's its evaluation seeds (:mod:`d3dwa_bullet.evaluation.seed_tables`). Groups:
the shipped world groups (train, unseen, real) of a ``d3dwa eval`` directory, or the layout
groups (shipped, generated, BARN's terciles) of a ``d3dwa sweep`` directory, each under its
noise, with the unseen layouts also by generator style when there are several and BARN's worlds
also pooled (``barn``) when the sweep holds other layouts too; then every layout under each
noise, then all tasks.

Beside each P(A > B), a test paired by layout: the one-sided Wilcoxon signed-rank p-value of
A > B over the (layout, noise, evaluation seed) both ran, each side's success there averaged
over its training seeds (:mod:`d3dwa_bullet.evaluation.paired`, docs/design/learning-protocol.md#paired-test).
``--methods A`` alone, A a learned method, compares A with both its floors present in DIR
(every step and held).

Then the readings (:mod:`d3dwa_bullet.evaluation.readings`, docs/design/readings.md#readings): paired by
layout (each side averaged over its training and evaluation seeds there), per group and
overall, for success, the score and BARN's official score, the mean difference with its 95 %
interval, the one-sided paired t-tests, TOST against the margins (``--margin-success`` in
points, ``--margin-score``, ``--margin-barn``), and one reading of four. Results from before the
score read on success alone. Two methods that share one layout get everything else and a line
saying why the paired test and the readings are absent; sharing no layout is refused.

A side whose policy trained on BARN worlds (its directory's meta.json ``settings.barn_training``)
has a line naming them, and each group holding some of them is flagged: ``† (k of n trained
on)`` in the P(A > B) table, ``† (A: k of n trained on)`` when both sides trained
(``evaluation.training_worlds``); in the readings, whose long cells leave the group little
room, ``†`` and a column "trained on" (``k of n``). ``--json`` gives each group record (its
P(A > B) and its readings) ``trained_on``: {side: {"trained": k, "worlds": n}} for each side
that trained on k > 0 of its n worlds ({} when neither did).

``--against DIR2`` takes B's runs from a second directory: the same method with and without
the recovery layer (``d3dwa compare rec --against norec --methods dwa3,dwa3``), whose runs
never share a directory. Each side is labelled with its recovery setting.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.margins import (
    MARGIN_OPTIONS,
    MARGINS,
    METRIC_NAMES,
    check_margin,
    option_value,
)
from d3dwa_bullet.learning.agents.barn_record import BarnTraining
from d3dwa_bullet.world.barn import barn_index
from d3dwa_bullet.world.barn_difficulty import TERCILE_GROUPS, barn_tercile_group


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
    for metric, option in MARGIN_OPTIONS.items():
        points = metric == "success"
        p.add_argument(
            option,
            type=float,
            default=option_value(metric, MARGINS[metric]),
            metavar="POINTS" if points else "DELTA",
            help=f"equivalence margin of the {METRIC_NAMES[metric]}"
            + (" in success points" if points else "")
            + ", stated before the run (default %(default)g; docs/design/readings.md#readings)",
        )
    p.add_argument("--json", action="store_true", help="print the records as JSON")
    p.set_defaults(func=cmd_compare)


def margins_of(args: argparse.Namespace) -> dict[str, float]:
    """The margins of the readings, each in its metric's units (success as a fraction), checked
    (ConfigError naming the option) before anything is read."""
    return {
        metric: check_margin(getattr(args, option[2:].replace("-", "_")), metric)
        for metric, option in MARGIN_OPTIONS.items()
    }


def _groups_of(
    row: dict[str, Any],
    shipped: dict[str, str],
    style_of: Callable[[Any], str | None] | None = None,
    barn_pooled: bool = False,
) -> list[str]:
    """The groups of a row, finest first, each named with its noise profile (``real, noise
    none``: the world group ``real`` and the profile ``real`` cannot be mixed up). style_of: a sweep's unseen layout is also in its
    generator style's group (a stratum), before the pooled ``generated``. barn_pooled: a BARN
    world's tercile group is pooled in ``barn`` (a sweep that also holds other layouts)."""
    noise = f"noise {row['noise']}"  # said as noise: a world group named real is no profile
    if "layout" in row:  # a sweep's row
        style = style_of(row) if style_of else None
        finer = [f"{style}, {noise}"] if style else []
        pool = [f"barn, {noise}"] if barn_pooled and row["layout"] in TERCILE_GROUPS else []
        return [*finer, f"{row['layout']}, {noise}", *pool, f"all layouts, {noise}"]
    barn_id = barn_index(row["world"])  # a BARN world of an eval: its difficulty tercile
    group = shipped.get(row["world"], "custom") if barn_id is None else barn_tercile_group(barn_id)
    return [f"{group}, {noise}", f"all worlds, {noise}"]


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

    args.margins = margins_of(args)
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


def trained_sides(
    out: Path, other: Path, sides: dict[str, tuple[str, str]]
) -> dict[str, BarnTraining]:
    """Side key -> the BARN worlds its method's policy trained on, as its directory's
    meta.json keeps them (sides: key -> (method, label), A's from out, B's from other)."""
    # start-up cost: SciPy's bootstrap (~0.5 s); no simulator, no torch
    from d3dwa_bullet.evaluation.results import read_meta
    from d3dwa_bullet.evaluation.training_worlds import read_barn_training

    found = {}
    for (key, (method, _)), folder in zip(sides.items(), (out, other), strict=True):
        record = read_barn_training(folder, read_meta(folder)).get(method)
        if record is not None:
            found[key] = record
    return found


def score_forms(out: Path, other: Path) -> str | None:
    """The score form (meta.json settings "score_form") both directories share; None when
    neither names one (results from before the score). ResultsError naming both forms when
    they differ: a comparison never mixes two forms of the score."""
    # start-up cost: SciPy's bootstrap (~0.5 s); no simulator, no torch
    from d3dwa_bullet.evaluation.results import read_meta

    forms = [read_meta(d).get("settings", {}).get("score_form") for d in (out, other)]
    if None not in forms and forms[0] != forms[1]:
        raise ResultsError(
            f"{out / 'meta.json'} has score form {forms[0]!r}, {other / 'meta.json'} has "
            f"{forms[1]!r}: compare runs of one score form"
        )
    return forms[0] if forms[0] is not None else forms[1]


def _compare(args: argparse.Namespace, a: str, b: str) -> None:
    # start-up cost: SciPy (~0.5 s), only for this command
    from d3dwa_bullet.evaluation.paired import (
        check_layouts,
        paired_by_group,
        paired_scores,
        unit_of,
    )
    from d3dwa_bullet.evaluation.readings import readings_by_group
    from d3dwa_bullet.evaluation.recipe_tables import recipe_by_group
    from d3dwa_bullet.evaluation.seed_tables import improvement
    from d3dwa_bullet.evaluation.style_tables import style_of, styles_present
    from d3dwa_bullet.evaluation.training_worlds import trained_counts, trained_worlds
    from d3dwa_bullet.method_specs import method_label
    from d3dwa_bullet.world.registry import world_groups

    same = a == b
    out = Path(args.dir)
    other = Path(args.against) if args.against else out
    rows_a, rec_a, complete_a = _side(out, a)
    rows_b, rec_b, complete_b = _side(other, b, warn=other != out)
    form = score_forms(out, other)
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
    absent = check_layouts(paired_scores(rows, key_a, key_b), a, b, source)
    by_style = style_of if len(styles_present(rows)) > 1 else None
    mixed = len({r["layout"] in TERCILE_GROUPS for r in rows if "layout" in r}) == 2
    groups_of = partial(_groups_of, shipped=world_groups(), style_of=by_style, barn_pooled=mixed)
    records = improvement(rows, key_a, key_b, groups_of)
    by_seed = args.pair_by == "layout-seed"
    if absent is None:
        group_of = {unit_of(r, by_seed): groups_of(r) for r in rows}
        paired = paired_by_group(rows, key_a, key_b, group_of, by_seed)
        layout_groups = {unit_of(r, False): groups_of(r) for r in rows}
        readings = readings_by_group(rows, key_a, key_b, layout_groups, args.margins)
        recipe, args.recipe_why = recipe_by_group(rows, key_a, key_b, groups_of, args.margins)
        for record in records:
            test = paired.get(record["group"], {})
            record |= {f"paired_{k}": v for k, v in test.items()}
            record["readings"] = readings.get(record["group"], {})
            record["recipe"] = recipe.get(record["group"], {})
    sides = {key_a: (a, labels[key_a]), key_b: (b, labels[key_b])}
    training = trained_sides(out, other, sides)
    groups = {g: {r["world"] for r in rows if g in ("all", *groups_of(r))}
              for g in (r["group"] for r in records)}  # fmt: skip
    names = trained_worlds(training)
    for record in records:  # its P(A > B) and its readings: the same group of worlds
        worlds = groups[record["group"]]
        counts = trained_counts(names, worlds).items()
        record["trained_on"] = {k: {"trained": n, "worlds": len(worlds)} for k, n in counts}
    if args.json:
        print(json_text({"results": str(out), "against": str(other), "a": a, "b": b,
                          "recovery_a": rec_a, "recovery_b": rec_b, "pair_by": args.pair_by,
                          "score_form": form, "margins": args.margins, "no_paired_test": absent,
                          "complete": complete_a and complete_b, "groups": records,
                          "recipe_why": getattr(args, "recipe_why", None),
                          "barn_training": {k: t.to_dict() for k, t in training.items()}}))  # fmt: skip
        return
    _print(args, rows, records, sides, source, absent, (training, groups))


def _print(
    args: argparse.Namespace,
    rows: list[dict[str, Any]],
    records: list[dict[str, Any]],
    sides: dict[str, tuple[str, str]],
    source: str,
    absent: str | None,
    trained: tuple[dict[str, BarnTraining], dict[str, set[str]]] = ({}, {}),
) -> None:
    """The tables of :func:`_compare`: P(A > B) with the Wilcoxon test beside it, then the
    readings; with one shared layout, P(A > B), the success and time tables, and why no
    paired test is given. trained: (side key -> its BARN training worlds, group -> its
    worlds): each side that trained on BARN worlds has its line, and its cells and groups on
    them a mark (``training_worlds``)."""
    from d3dwa_bullet.evaluation.page_width import fit_prose
    from d3dwa_bullet.evaluation.readings import NO_SCORE, readings_table
    from d3dwa_bullet.evaluation.recipe_tables import recipe_section
    from d3dwa_bullet.evaluation.seed_tables import improvement_table, seed_tables
    from d3dwa_bullet.evaluation.training_worlds import (
        MARK,
        cell_mark,
        group_count,
        group_flag,
        trained_worlds,
        training_lines,
    )

    training, members = trained
    trained_names = trained_worlds(training)
    worlds = sorted({r["world"] for r in rows})
    print(fit_prose(training_lines(training, worlds)), end="")
    both = dict(zip(sides, "AB", strict=True)) if len(training) > 1 else None  # whose flag
    flag = group_flag(trained_names, both)
    marked = [r | {"group": r["group"] + "".join(flag(k, members[r["group"]]) for k in training)}
              for r in records]  # fmt: skip
    # the readings' groups: the mark, and their counts in a column (a flagged group is a key
    # of every part of the split table, and the long reading cell leaves it little room)
    count = group_count(trained_names, both)
    counts = {
        g: ", ".join(filter(None, (count(k, w) for k in training))) for g, w in members.items()
    }
    flagged = {g: g + (f" {MARK}" if counts[g] else "") for g in members}

    (key_a, (_, la)), (key_b, (_, lb)) = sides.items()
    labels = {k: label for k, (_, label) in sides.items()}
    by_seed = args.pair_by == "layout-seed"
    unit, pooled = (
        ("(layout, noise, evaluation seed)", "training seeds")
        if by_seed
        else ("(layout, noise)", "training and evaluation seeds")
    )
    paired = (
        ""
        if absent
        else f" Paired by {unit}, each side's success averaged over its {pooled}: A better / "
        "worse in how many pairs, and the one-sided Wilcoxon signed-rank p-value of A > B."
    )
    print(
        fit_prose(
            f"P(A > B), A = {la}, B = {lb}, on success per task (world, noise); 95 % stratified bootstrap "
            f"over runs; 0.5 = no difference.{paired} From {source}.\n"
        )
    )
    print(improvement_table(marked, key_a, key_b, labels), end="")
    if absent:
        mark = cell_mark(trained_names)
        print("\n" + seed_tables(rows, [key_a, key_b], worlds, sides, mark), end="")
        print(fit_prose(f"\n{absent}"))
        print(fit_prose("\nReading: inconclusive (one shared layout cannot decide; see above)."))
        return
    seeds = {int(r["seed"]) for r in rows}
    if by_seed and len(seeds) > 1:
        print(
            fit_prose(
                f"\n{len(seeds)} evaluation seeds share each layout, so these pairs are not "
                "independent (without noise a fixed or greedy method repeats its episode at "
                "every seed): `--pair-by layout` is the conservative test "
                "(docs/design/learning-protocol.md#paired-test)."
            )
        )
    print(
        fit_prose(
            f"\nReadings about these policies (training seeds fixed), A = {la}, B = {lb}: paired "
            "by layout (each side averaged over its training and evaluation seeds there); A - B "
            "with its 95 % t interval (success in points), the smaller one-sided paired t "
            "p-value, TOST's p against the margin; a difference reads at p < 0.025 each way, equivalence at "
            "TOST p < 0.05 "
            "(docs/design/readings.md#readings).\n"
        )
    )
    readings = {r["group"]: r["readings"] for r in records}
    lacking = [m for m, r in readings["all"].items() if r.get("why") == NO_SCORE]
    shown = {flagged[g]: {m: r for m, r in per.items() if m not in lacking}
             for g, per in readings.items()}  # fmt: skip
    trained_on = {flagged[g]: c for g, c in counts.items()} if any(counts.values()) else None
    print(readings_table(shown, trained_on), end="")
    recipe = {flagged[r["group"]]: r["recipe"] for r in records}
    print(recipe_section(recipe, args.recipe_why, (la, lb), lacking, trained_on), end="")
    if lacking:
        names = " and ".join(METRIC_NAMES[m] for m in lacking)
        print(fit_prose(f"\n{names}: {NO_SCORE}; success reads alone."))
