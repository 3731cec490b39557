"""Both questions per world family, Holm-controlled: the records and tables of a plan's headline.

For each cell (A, B, profile), world family and metric, two readings of the same rows
(:func:`recipe.both_readings`): **these policies** (the training seeds fixed: today's reading)
and **the recipe** (the training seed a random effect). The headline reads per world family,
each with its own N: BARN's worlds (the layout groups of BARN's difficulty terciles) and the
R-style generated layouts (a sweep row with a generator style); the pool of both is printed
after them, marked secondary, its p-values unadjusted. Holm's procedure
(:func:`multiplicity.holm`) runs per (question, metric) over every headline (cell, family):
the yardstick's 24 cells x 2 families = 48 tests a metric (docs/design/readings-recipe.md).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.margins import margin_text
from d3dwa_bullet.evaluation.multiplicity import holm
from d3dwa_bullet.evaluation.page_width import fit_prose, split_columns
from d3dwa_bullet.evaluation.paired import Row
from d3dwa_bullet.evaluation.readings import metric_text, readings_table
from d3dwa_bullet.evaluation.recipe import (
    QUESTIONS,
    Cells,
    both_readings,
    cell_means,
    check_recipe_side,
    read_cells,
)
from d3dwa_bullet.evaluation.style_tables import style_of
from d3dwa_bullet.world.barn_difficulty import TERCILE_GROUPS
from d3dwa_bullet.world.barn_style import GROUP as BARN_STYLE

FAMILIES = ("BARN", "R-style")
"""The headline's world families, in the tables' order."""
POOLED = "pooled"
"""The secondary row: every layout of both families."""


def family_of(row: Row) -> str | None:
    """A sweep row's world family: BARN for a BARN world (its tercile group) or a fresh
    BARN-style one (issue 79: one family, BARN's recipe), R-style for a generated layout with a
    style; None for any other row."""
    if row.get("layout") in TERCILE_GROUPS or row.get("layout") == BARN_STYLE:
        return "BARN"
    return "R-style" if style_of(row) else None


def read_families(
    rows: Sequence[Row], cells: Sequence[tuple[str, str, str]], margins: Mapping[str, float]
) -> list[dict[str, Any]]:
    """One record per (cell (A, B, profile), family, question, metric): {"a", "b", "profile",
    "family" (FAMILIES or POOLED), "question", **both_readings' record}; the headline records
    (not POOLED) Holm-adjusted per (question, metric), the pooled ones marked "adjusted": None.
    ResultsError naming a learned side with one training seed."""
    by: dict[tuple[str, str, str], list[Row]] = defaultdict(list)
    for r in rows:
        fam = family_of(r)
        if fam is not None:
            by[(r["noise"], r["method"], fam)].append(r)
    for m in dict.fromkeys(m for a, b, _ in cells for m in (a, b)):
        check_recipe_side(rows, m)
    means: dict[tuple[str, str, str, str], Cells] = {}

    def side(profile: str, method: str, fams: Sequence[str], metric: str) -> Cells:
        out: Cells = {}
        for f in fams:
            key = (profile, method, f, metric)
            if key not in means:
                means[key] = cell_means(by.get(key[:3], ()), method, metric)
            out |= means[key]
        return out

    out = []
    for a, b, profile in cells:
        for fam in (*FAMILIES, POOLED):
            names = FAMILIES if fam == POOLED else (fam,)
            if not all(by.get((profile, m, f)) for m in (a, b) for f in names if fam != POOLED):
                continue
            for metric, margin in margins.items():
                ca, cb = (side(profile, m, names, metric) for m in (a, b))
                if not ca or not cb:
                    continue
                for q, rec in read_cells(ca, cb, metric, margin).items():
                    out.append(
                        {"a": a, "b": b, "profile": profile, "family": fam, "question": q} | rec
                    )
    families: dict[tuple[str, str], list[int]] = defaultdict(list)
    for i, r in enumerate(out):
        if r["family"] != POOLED:
            families[(r["question"], r["metric"])].append(i)
    for idx in families.values():
        for i, adjusted in zip(idx, holm([out[i] for i in idx]), strict=True):
            out[i] = adjusted
    for r in out:
        r.setdefault("adjusted", None)
    return out


_SHORT = {"A better": "**A**", "B better": "**B**", "equivalent": "eq.", "inconclusive": "inc."}


def _entry(r: Mapping[str, Any] | None) -> str:
    """A reading, A - B and its 95 % interval (success in points); '--' without one."""
    if r is None or r.get("reading") is None or r.get("low") is None:
        return "--" if r is None or r.get("reading") is None else _SHORT[r["reading"]]
    m = r["metric"]
    low, high = (metric_text(m, r[k], True) for k in ("low", "high"))
    return f"{_SHORT[r['reading']]} {metric_text(m, r['difference'], True)} [{low}, {high}]"


def family_table(
    records: Sequence[Mapping[str, Any]], question: str, metric: str, pooled: bool = False
) -> str:
    """A Markdown table of one question and metric: a line per (cell, profile), a column per
    family (the headline's, or POOLED alone), each the reading, A - B and its 95 % interval,
    preceded by a line saying which question it answers, its N and whether p is adjusted."""
    mine = [r for r in records if r["question"] == question and r["metric"] == metric
            and (r["family"] == POOLED) == pooled]  # fmt: skip
    if not mine:
        return ""
    fams = [POOLED] if pooled else [f for f in FAMILIES if any(r["family"] == f for r in mine)]
    lines: dict[tuple[str, str], dict[str, Mapping[str, Any]]] = {}
    n: dict[str, int] = {}
    for r in mine:
        lines.setdefault((f"`{r['a']}` vs `{r['b']}`", r["profile"]), {})[r["family"]] = r
        n[r["family"]] = max(n.get(r["family"], 0), r["layouts"])
    head = ["A vs B", "profile", *(f"{f} ({n[f]:,} layouts)" for f in fams)]
    body = [[*key, *(_entry(per.get(f)) for f in fams)] for key, per in lines.items()]
    labels = {r["adjusted"] for r in mine}
    adjusted = (
        "p-values unadjusted (secondary)" if pooled else
        f"difference and TOST p-values Holm-adjusted ({', '.join(sorted(x for x in labels if x))} tests)"
    )  # fmt: skip
    margin = margin_text(metric, mine[0]["margin"])
    unit = ", A - B in points" if metric == "success" else ""
    title = f"**{QUESTIONS[question]}**: {metric} (margin {margin}){unit}; {adjusted}."
    return f"{title}\n\n{split_columns(head, ['---'] * len(head), body, keys=2)}"


RECIPE_NOTE = (
    "seeds and layouts crossed, both random; 95 % interval on Satterthwaite df; p-values unadjusted; "
    "docs/design/readings-recipe.md"
)
"""How a plan tool's recipe table is read, in its heading."""

LEGEND = (
    "**A**: A better, **B**: B better, eq.: equivalent within the margin, inc.: inconclusive; "
    "A - B [95 % interval]. The recipe's interval carries the training seeds' spread as well as the "
    "layouts' (Satterthwaite df); these policies' carries the layouts' alone."
)


def recipe_by_group(
    rows: Sequence[Row],
    a: str,
    b: str,
    groups_of: Callable[[Row], Sequence[str]],
    margins: Mapping[str, float],
) -> tuple[dict[str, dict[str, dict[str, Any]]], str | None]:
    """({group: {metric: the recipe's record}} over each row's groups and "all", why none is
    read): {} with why when neither side is learned or a learned side has one training seed
    (the line of :func:`recipe.check_recipe_side`), or ({}, None) when neither side is learned
    (no seed to be random); unadjusted, as ``compare`` prints them."""
    try:
        seeds = [check_recipe_side(rows, m) for m in (a, b)]
    except ResultsError as e:
        return {}, str(e)
    if not any(seeds):
        return {}, None  # no seed to be random: the recipe is these policies
    buckets: dict[str, list[Row]] = defaultdict(list)
    for r in rows:
        if r["method"] in (a, b):
            for g in [*groups_of(r), "all"]:
                buckets[g].append(r)
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for g, here in buckets.items():
        if any(r["method"] == a for r in here) and any(r["method"] == b for r in here):
            out[g] = {
                m: both_readings(here, a, b, m, margin)["recipe"] for m, margin in margins.items()
            }
    return out, None


def recipe_section(
    readings: Mapping[str, Mapping[str, Mapping[str, Any]]],
    why: str | None,
    labels: tuple[str, str],
    lacking: Collection[str] = (),
    trained_on: Mapping[str, str] | None = None,
) -> str:
    """``compare``'s second readings table, the recipe's (``readings_table`` of
    :func:`recipe_by_group`'s records, unadjusted, the metrics lacking a score left out),
    under a line saying which question it answers; one line saying why when none is read ("" when
    there is no why: neither side is learned)."""
    la, lb = labels
    readings = {
        g: {m: r for m, r in per.items() if m not in lacking} for g, per in readings.items() if per
    }
    if not readings:
        return (
            ""
            if why is None
            else fit_prose(f"\nThe recipe (training seed random): not read: {why}.\n")
        )
    head = (
        f"\nReadings about the recipe (training seed random), A = {la}, B = {lb}: what another draw "
        "of training seeds would give. Seeds and layouts crossed, both random; A - B with its 95 % "
        "interval (Satterthwaite df), p-values unadjusted; the same rule "
        "(docs/design/readings-recipe.md).\n"
    )
    return fit_prose(head) + "\n" + readings_table(readings, trained_on)


def families_page(
    records: Sequence[Mapping[str, Any]], margins: Mapping[str, float], plan: str
) -> str:
    """The per-family page of a plan's cells: for each metric of margins (the headline score
    first), the recipe's table and these policies', each per family and Holm-adjusted, then
    the pooled rows of both questions, marked secondary; the legend last."""
    order = sorted(margins, key=lambda m: m != "score")
    parts = [
        f"Readings of {plan} per world family, both questions (docs/design/readings-recipe.md). The headline "
        "is the recipe, per family; the pool of both families is secondary. An interval is the unadjusted 95 % "
        "one; a reading is taken on the Holm-adjusted p-values, so a cell can read inconclusive while its "
        "interval excludes 0.\n"
    ]
    titles = {
        "score": "Robot score (the headline metric)",
        "success": "Success",
        "score_barn": "BARN's official score",
    }
    for metric in order:
        parts.append(f"### {titles.get(metric, metric)}\n")
        parts += [family_table(records, q, metric) + "\n" for q in QUESTIONS]
    parts.append("### The pool of both families (secondary)\n")
    for metric in order:
        parts += [family_table(records, q, metric, pooled=True) + "\n" for q in QUESTIONS]
    parts.append(LEGEND)
    return fit_prose("\n".join(p.rstrip("\n") + "\n" for p in parts if p.strip()))


def as_strata(records: Sequence[Mapping[str, Any]], question: str) -> list[dict[str, Any]]:
    """The family records of one question shaped as ``plan_readings.read_cells``' records
    with strata (one per (cell, profile), "strata": {family: {metric: record}}), for
    ``readings_figure.draw`` to draw a family's cells."""
    out: dict[tuple[str, str, str], dict[str, Any]] = {}
    for r in records:
        if r["question"] == question:
            cell = out.setdefault((r["a"], r["b"], r["profile"]),
                                  {"a": r["a"], "b": r["b"], "profile": r["profile"], "readings": {}, "strata": {}})  # fmt: skip
            cell["strata"].setdefault(r["family"], {})[r["metric"]] = r
    return list(out.values())
