"""The readings a committed plan asks for, from its finished results directory, in one table.

A plan (docs/pilots/*/plan.md) fixes its cells, its margins and its rule before its sweep
runs; this tool takes exactly those readings, once, at the plan's N: ``d3dwa compare``'s rule
(docs/design/readings.md#readings) on every cell, under each profile, paired by layout (each side
averaged over its training and evaluation seeds there). It refuses a directory that is not
finished: the plans read once, and a partial directory is a progress report, not an answer.

- ``--plan yardstick``: docs/pilots/yardstick-barn/plan.md's eight headline pairs.
- ``--plan barn-trained``: docs/pilots/barn-trained/plan.md's cells on BARN ``challenge``.
- ``--plan barn-trained-r-style``: that plan's R-style cells (each BARN-trained method
  against its shipped twin).
- ``--pair A,B`` (repeatable) for cells of your own; B may be ``best-fixed``.

``best-fixed`` is, under each profile, the fixed DWA (``dwa1``, ``dwa2``, ``dwa3``, those the
directory holds) with the highest mean robot score over that profile's episodes in the same
directory, as the BARN-trained plan defines it. The table names which one it was.

    python -m tools.experiments.plan_readings runs/barn-trained/challenge --plan barn-trained
    python -m tools.experiments.plan_readings runs/yardstick-barn --plan yardstick --json

``--strata`` reads each cell also per stratum fixed before the run: a BARN world's difficulty
tercile (``barn-easy`` ...) and BARN pooled (``barn``), a generated layout's style (``R1-style``
...) and the styles pooled (``generated``); it prints the brief tables with a line per (cell,
stratum), or with ``--json`` adds each record's ``strata``. The plan's answer stays the pooled
cell; a stratum is a finer look with fewer layouts.

``--figure PATH`` also draws the cells' A - B with their intervals against the margins
(tools/experiments/readings_figure.py), whatever the text printed; ``--figure-stratum NAME``
draws that stratum's readings instead of the pooled cells (``barn``: BARN's worlds alone).

``--question`` (default ``both``): each cell's readings about **these policies** (the training
seeds fixed, as above) and, where a side is learned, about **the recipe** (the training seed a
random effect: what another draw of seeds would give; docs/design/readings-recipe.md), each
table saying which; ``policies`` or ``recipe`` prints one. A learned side with one training
seed: ``both`` says why its recipe is not read, ``recipe`` refuses it (one line, exit 2).

``--families`` prints the page that reads the plan per world family instead (BARN's worlds;
the R-style generated layouts; each with its own N), both questions, the p-values Holm-adjusted
over every (cell, family) per question and metric, the pool of both families after them, marked
secondary and unadjusted (docs/pilots/yardstick-barn/sweep/recipe-readings.md prints it). It
refuses a learned side with one training seed. With ``--figure PATH`` it also draws the recipe's
readings, a figure per family (PATH's name + ``_barn``, ``_r-style``).

``--brief`` prints two tables instead, the robot score's and success's, one line per cell and a
column per profile: the reading and A - B (success in points; **A**: A better, **B**: B better,
"eq.": equivalent within the margin, "inc.": inconclusive), as docs/results.md quotes them.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from statistics import fmean
from typing import Any

from d3dwa_bullet.cli.compare import job_rows_of
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation import recipe_tables
from d3dwa_bullet.evaluation.margins import MARGIN_OPTIONS, MARGINS, check_margin, margin_text
from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.paired import Unit, metric_value
from d3dwa_bullet.evaluation.readings import metric_text, readings_by_group, readings_table
from d3dwa_bullet.evaluation.results import completion
from d3dwa_bullet.evaluation.style_tables import style_of
from d3dwa_bullet.method_specs import FIXED
from d3dwa_bullet.world.barn_difficulty import TERCILE_GROUPS
from tools.entry import ToolParser, tool_main

QUESTIONS = ("both", "policies", "recipe")
"""--question: which readings a cell prints (both: the recipe too where a side is learned)."""
BEST_FIXED = "best-fixed"
"""The B of a cell that stands for the best fixed DWA of each profile."""

Rows = Sequence[Mapping[str, Any]]


@dataclass(frozen=True)
class Plan:
    """A committed plan's cells (A, B) and its margins (metric -> margin)."""

    page: str
    pairs: tuple[tuple[str, str], ...]
    margins: Mapping[str, float] = field(default_factory=lambda: dict(MARGINS))


_BARN = ("d3dwa-barn", "d3dwa-weights-barn", "d3dwa-dr-barn")
_QUESTIONS = (
    ("d3dwa", "d3dwa-weights"),
    ("d3dwa-dr", "d3dwa"),
    ("d3dwa-dr", "dwa3"),
    ("d3dwa", "random@10"),
    ("d3dwa-dr", "random@10"),
    ("d3dwa-weights", "random-weights@10"),
)
"""The three questions' six pairs, (a), (b) twice, (c) thrice: issue 79's plan reads these; the
yardstick read them with each learned method against DWA III."""
PLANS = {
    "yardstick": Plan(
        "docs/pilots/yardstick-barn/plan.md",
        (*_QUESTIONS, ("d3dwa", "dwa3"), ("d3dwa-weights", "dwa3")),
        MARGINS | {"success": 0.05},
    ),
    "barn-trained": Plan(
        "docs/pilots/barn-trained/plan.md",
        (
            ("d3dwa-barn", BEST_FIXED),
            ("d3dwa-barn", "random@10"),
            ("d3dwa-dr-barn", "d3dwa-barn"),
            ("d3dwa-dr-barn", BEST_FIXED),
            ("d3dwa-barn", "d3dwa-weights-barn"),
            ("d3dwa-dr-barn", "random@10"),
            ("d3dwa-weights-barn", "random-weights@10"),
            *((m, m.removesuffix("-barn")) for m in _BARN),
        ),
    ),  # fmt: skip
    "recipes": Plan("docs/pilots/recipes/plan.md", _QUESTIONS, MARGINS | {"success": 0.05}),
    "barn-trained-r-style": Plan(
        "docs/pilots/barn-trained/plan.md", tuple((m, m.removesuffix("-barn")) for m in _BARN)
    ),
}
"""The committed plans, by name: what each reads is fixed by its page, never by a result."""


def finished_rows(out: Path) -> list[dict[str, Any]]:
    """The rows of a finished results directory; ResultsError naming the directory when it is
    not one, or when episodes of its job list are still missing."""
    rows = job_rows_of(out)
    done, expected = completion(out, rows)
    if done != expected:
        raise ResultsError(
            f"{out}: {done} of {expected} episodes finished; a plan reads once, at its N "
            "(a partial directory is a progress report: `d3dwa compare` prints one)"
        )
    return rows


def best_fixed(rows: Rows) -> dict[str, tuple[str, float]]:
    """Profile -> (the fixed DWA with the highest mean robot score under it, that mean); the
    first of FIXED's order on a tie. ResultsError when the rows hold no fixed DWA."""
    out: dict[str, tuple[str, float]] = {}
    for profile in dict.fromkeys(r["noise"] for r in rows):
        means = {}
        for m in FIXED:
            values = [metric_value(r, "score") for r in rows
                      if r["method"] == m and r["noise"] == profile]  # fmt: skip
            if values and None not in values:
                means[m] = fmean(v for v in values if v is not None)
        if not means:
            raise ResultsError(f"no fixed DWA with a score under {profile!r} for {BEST_FIXED}")
        out[profile] = max(means.items(), key=lambda kv: kv[1])  # max keeps the first on a tie
    return out


def strata_of(row: Mapping[str, Any]) -> list[str]:
    """The strata of a sweep's row, finest first: a BARN world's tercile group and ``barn``, a
    generated layout's style and ``generated``; none for any other row."""
    layout = str(row.get("layout", ""))
    if layout in TERCILE_GROUPS:
        return [layout, "barn"]
    style = style_of(row)
    return [style, "generated"] if style else []


def _stratum_order(name: str) -> tuple[int, int, str]:
    """BARN's terciles (easiest first), BARN pooled, the styles, the styles pooled."""
    if name in TERCILE_GROUPS:
        return (0, TERCILE_GROUPS.index(name), name)
    return (1, 0, name) if name == "barn" else (3, 0, name) if name == "generated" else (2, 0, name)


def read_cells(
    rows: Rows,
    pairs: Sequence[tuple[str, str]],
    margins: Mapping[str, float],
    strata: Callable[[Mapping[str, Any]], Sequence[str]] | None = None,
    question: str = "policies",
) -> list[dict[str, Any]]:
    """One record per (cell, profile): {"a", "b", "profile", "readings": {metric: reading}}
    (``readings_by_group``'s records, these policies', the profile the group); with strata (a
    row's strata), also "strata": {stratum: {metric: reading}}; unless question is "policies",
    also "recipe": {metric: the recipe's reading} ({} with "recipe_why" where a learned side
    has one training seed; question "recipe" refuses that). ResultsError naming a method of
    a cell the rows lack."""
    present = {r["method"] for r in rows}
    for name in dict.fromkeys(m for pair in pairs for m in pair):  # the cells' order
        if name != BEST_FIXED and name not in present:
            raise ResultsError(
                f"no rows of method {name!r} (present: {', '.join(sorted(present))})"
            )
    best = best_fixed(rows) if any(b == BEST_FIXED for _, b in pairs) else {}
    out = []
    for a, b in pairs:
        for profile in dict.fromkeys(r["noise"] for r in rows):
            other = best[profile][0] if b == BEST_FIXED else b
            here = [r for r in rows if r["noise"] == profile and r["method"] in (a, other)]
            groups: dict[Unit, list[str]] = {
                (r["world"], profile, None): [profile, *(strata(r) if strata else ())] for r in here
            }
            by_group = readings_by_group(here, a, other, groups, margins)
            readings = by_group.get(profile)
            if readings is None:  # no layout both sides ran under this profile
                continue
            record = {"a": a, "b": other, "profile": profile, "readings": readings}
            if strata:
                names = sorted(set(by_group) - {profile, "all"}, key=_stratum_order)
                record["strata"] = {name: by_group[name] for name in names}
            if b == BEST_FIXED:
                record["best_fixed_score"] = best[profile][1]
            if question != "policies":
                recipe, why = recipe_tables.recipe_by_group(here, a, other, lambda r: (), margins)
                if why is not None and question == "recipe":
                    raise ResultsError(why)
                record |= {"recipe": recipe.get("all", {}), "recipe_why": why}
            out.append(record)
    return out


def markdown(records: Sequence[Mapping[str, Any]], plan: str, question: str = "policies") -> str:
    """A section per cell: its title (B named as the best fixed DWA where it is one), then
    ``readings_table`` with a row per (profile, metric), for each question the records hold
    (:func:`_questions`)."""
    parts = [f"Readings of {plan}: paired by layout, each side averaged over its seeds there; "
             "success in points (docs/design/readings.md#readings).\n"]  # fmt: skip
    cells: dict[tuple[str, str | bool], list[Mapping[str, Any]]] = {}
    for r in records:
        cells.setdefault((r["a"], "best_fixed_score" in r or r["b"]), []).append(r)
    for (a, b), per in cells.items():
        questions = _questions(per, question)
        if b is True:
            named = ", ".join(
                f"{r['profile']}: `{r['b']}` ({r['best_fixed_score']:.3f})" for r in per
            )
            title = f"`{a}` (A) against the best fixed DWA (B)\n\nB by mean robot score: {named}."
        else:
            title = f"`{a}` (A) against `{b}` (B)"
        parts.append(f"### {title}\n\n" + "\n".join(questions))
    return fit_prose("\n".join(parts))


def _questions(per: Sequence[Mapping[str, Any]], question: str) -> list[str]:
    """A cell's readings tables, these policies' (unless question is "recipe") and the
    recipe's (when the records hold it), each under the question it answers, or a line saying
    why the recipe is not read."""
    out, both = [], "recipe" in per[0]
    if question != "recipe":
        table = readings_table({r["profile"]: r["readings"] for r in per})
        out.append(("**These policies** (training seeds fixed):\n\n" if both else "") + table)
    if both and per[0].get("recipe_why"):
        out.append(f"**The recipe** (training seed random): not read: {per[0]['recipe_why']}.\n")
    elif both and any(r["recipe"] for r in per):
        table = readings_table({r["profile"]: r["recipe"] for r in per})
        out.append(
            f"**The recipe** (training seed random; {recipe_tables.RECIPE_NOTE}):\n\n{table}"
        )
    return out


_SHORT = {"A better": "**A**", "B better": "**B**", "equivalent": "eq.", "inconclusive": "inc."}
"""A reading as a brief table prints it."""
_BRIEF = {"score": "Robot score", "success": "Success"}
"""The metrics of a brief table, in its order, with their titles."""


def _brief_reading(metric: str, record: Mapping[str, Any] | None) -> str:
    """One metric's reading and A - B (success in points), or '--' without one."""
    if record is None or record.get("reading") is None:
        return "--"
    diff = record["difference"]
    if diff is None:
        return _SHORT[record["reading"]]
    return f"{_SHORT[record['reading']]} {metric_text(metric, diff, signed=True)}"


def brief(
    records: Sequence[Mapping[str, Any]], margins: Mapping[str, float], strata: bool = False
) -> str:
    """For the robot score, then success: a Markdown table with one line per cell (A vs B;
    "best fixed" where B stands for it) and a column per profile, each the reading and A - B;
    with strata, a stratum column and a line per (cell, stratum) after each cell's pooled line."""
    profiles = list(dict.fromkeys(r["profile"] for r in records))
    lines: dict[tuple[str, ...], dict[str, Mapping[str, Any]]] = {}
    for r in records:
        b = "best fixed" if "best_fixed_score" in r else f"`{r['b']}`"
        cell = f"`{r['a']}` vs {b}"
        lines.setdefault((cell, "pooled") if strata else (cell,), {})[r["profile"]] = r["readings"]
        for name, readings in r.get("strata", {}).items() if strata else ():
            lines.setdefault((cell, name), {})[r["profile"]] = readings
    head = ["A vs B", *(["stratum"] if strata else []), *profiles]
    parts = []
    for metric, title in _BRIEF.items():
        unit = " in points" if metric == "success" else ""
        body = [[*line, *(_brief_reading(metric, per.get(p, {}).get(metric)) for p in profiles)]
                for line, per in lines.items()]  # fmt: skip
        table = split_columns(head, ["---"] * len(head), body)
        within = margin_text(metric, margins[metric])
        by = " by stratum" if strata else ""
        parts.append(f"{title} (margin {within}){by}, the reading and A - B{unit}:\n\n{table}")
    where = (", per stratum: `d3dwa compare DIR --methods A,B`." if strata
             else ": without --brief.")  # fmt: skip
    legend = ("**A**: A better, **B**: B better, eq.: equivalent within the margin, inc.: "
              f"inconclusive; the intervals, p-values and layouts that would decide{where}")  # fmt: skip
    return "\n".join(parts) + f"\n{fit_prose(legend)}\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="plan_readings", description=__doc__.split("\n")[0])
    parser.add_argument("results", type=Path, help="the plan's finished results directory")
    parser.add_argument(
        "--plan", choices=sorted(PLANS), help="a committed plan's cells and margins"
    )
    parser.add_argument("--pair", action="append", default=[], metavar="A,B",
                        help=f"a cell of your own (repeatable); B may be {BEST_FIXED}")  # fmt: skip
    for metric, option in MARGIN_OPTIONS.items():
        parser.add_argument(option, type=float, metavar="M",
                            help=f"{metric}'s margin for --pair cells (a plan's are its own)")  # fmt: skip
    out = parser.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true")
    out.add_argument("--brief", action="store_true", help="one line per cell (see above)")
    parser.add_argument("--figure", type=Path, metavar="PNG",
                        help="also draw each cell's A - B and interval against its margin")  # fmt: skip
    parser.add_argument("--figure-stratum", metavar="NAME",
                        help="the figure draws this stratum (e.g. barn) instead of the pool")  # fmt: skip
    parser.add_argument("--strata", action="store_true",
                        help="also per stratum: BARN's terciles and styles (see above)")  # fmt: skip
    parser.add_argument("--question", choices=QUESTIONS, default="both",
                        help="these policies, the recipe, or both where a side is learned (see above)")  # fmt: skip
    parser.add_argument("--families", action="store_true",
                        help="both questions per world family, Holm-adjusted (see above)")  # fmt: skip
    args = parser.parse_args(argv)
    if bool(args.plan) == bool(args.pair):
        parser.error("give either --plan or --pair")
    given = {m: getattr(args, o[2:].replace("-", "_")) for m, o in MARGIN_OPTIONS.items()}
    if args.plan:
        if any(v is not None for v in given.values()):
            parser.error(f"--plan {args.plan} reads at its own committed margins; no --margin-*")
        plan = PLANS[args.plan]
        pairs, margins, name = list(plan.pairs), dict(plan.margins), plan.page
    else:
        pairs, name = [], "the given cells"
        for text in args.pair:
            names = [m.strip() for m in text.split(",")]
            if len(names) != 2 or not all(names) or names[0] == names[1]:
                parser.error(f"--pair needs two different methods A,B, got {text!r}")
            pairs.append((names[0], names[1]))
        margins = {m: MARGINS[m] if v is None else check_margin(v, m) for m, v in given.items()}
    if args.figure_stratum and not args.figure:
        parser.error("--figure-stratum needs --figure")
    strata = strata_of if args.strata or args.figure_stratum else None
    rows = finished_rows(args.results)
    if args.families:
        best = best_fixed(rows) if any(b == BEST_FIXED for _, b in pairs) else {}
        profiles = list(dict.fromkeys(r["noise"] for r in rows))
        cells = [(a, best[p][0] if b == BEST_FIXED else b, p) for a, b in pairs for p in profiles]
        found = recipe_tables.read_families(rows, cells, margins)
        page = recipe_tables.families_page(found, margins, name)
        print(json.dumps(found, indent=1) if args.json else page, end="")  # fmt: skip
        for family in recipe_tables.FAMILIES if args.figure else ():  # the recipe's, per family
            from tools.experiments.readings_figure import draw

            to, title = args.figure, f"The recipe's readings of {name} on {family}"  # fmt: skip
            to = to.with_name(f"{to.stem}_{family.lower()}{to.suffix}")
            draw(recipe_tables.as_strata(found, "recipe"), to, title, family)
        return 0
    question = "policies" if args.brief or args.strata else args.question
    records = read_cells(rows, pairs, margins, strata, question)
    if args.figure:
        from tools.experiments.readings_figure import draw

        where = args.figure_stratum
        present = sorted({s for r in records for s in r.get("strata", {})}, key=_stratum_order)
        if where is not None and where not in present:
            raise ResultsError(f"--figure-stratum {where!r}: no such stratum here (present: "
                               f"{', '.join(present) or 'none'})")  # fmt: skip
        of = f" on {where}" if where else ""
        title = f"Readings of {name}{of}: A - B, 95 % interval, margin shaded"
        draw(records, args.figure, title, where)
    if args.json:
        print(json.dumps(records, indent=1))
    elif args.strata:
        print(brief(records, margins, strata=True), end="")
    else:
        print(brief(records, margins) if args.brief else markdown(records, name, question), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
