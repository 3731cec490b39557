"""Readings: A against B, paired by layout, read as a difference, an equivalence or neither.

The unit is the layout under one noise profile: each side's value there (success, the score
or BARN's official score, :data:`~d3dwa_bullet.evaluation.paired.METRICS`) averaged over its
training seeds and evaluation seeds (``paired.paired_scores(..., by_seed=False)``). Over the n
layouts both ran, the differences d = A - B give (docs/design/readings.md#readings):

- the mean difference with its 95 % Student-t interval (``scipy.stats.ttest_1samp`` on d,
  the paired t-test);
- the one-sided paired t-test each way (A > B, and B > A);
- TOST, two one-sided tests of equivalence against +-margin, a margin stated before the
  run: H0 mean <= -margin and H0 mean >= +margin, each rejected at ALPHA; its p-value is
  the larger of the two (equivalence when the 90 % interval lies inside +-margin).

and the reading, exactly one of four (:func:`reading_of`):

- ``A better`` / ``B better``: the one-sided test that way rejects at ALPHA / 2, so the
  reading never disagrees with the printed 95 % interval (which then excludes 0) and a
  difference is claimed, either way, at most 5 % of the time when there is none;
- ``equivalent within +-margin``: otherwise, when TOST rejects at ALPHA;
- ``inconclusive (about N layouts would decide)``: otherwise; N is the fewer of the layouts
  the difference test or TOST would need for 80 % power if the observed mean and sd were
  the truth (normal approximation, ``paired.layouts_for_difference`` and
  ``paired.layouts_for_equivalence``).

A difference that is also within the margin reads as the difference, its equivalence kept
in the record (``equivalent``) and the text. The interval is cut to what a difference can be
(:data:`DIFFERENCE_RANGE`), and given as none, with why, where it spans all of it (two or three
layouts). Fewer than two layouts read as inconclusive with
why (a t-test needs two); layouts without the same spread (every difference equal) take the
t-test's limit (p 0 towards that difference); a NaN value gives no reading, naming the
layouts, never a NaN p-value. Pure: numpy and SciPy on the rows, no simulator, no torch.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from d3dwa_bullet.evaluation.margins import margin_text
from d3dwa_bullet.evaluation.page_width import RIGHT, split_columns
from d3dwa_bullet.evaluation.paired import (
    MIN_LAYOUTS,
    Row,
    Unit,
    layouts_for_difference,
    layouts_for_equivalence,
    mean_sd,
    metric_value,
    paired_scores,
)

ALPHA = 0.05
"""TOST's level; each direction of the difference test takes ALPHA / 2."""
POWER = 0.8
"""The power a planned number of layouts aims at."""
READINGS = ("A better", "B better", "equivalent", "inconclusive")
NO_SCORE = "no score: results from before the score"
#: What A - B can be in every metric: each lies in [0, 1] (success a fraction of episodes;
#: the score and BARN's official score at most 1), so an interval is cut to [-1, 1].
DIFFERENCE_RANGE = (-1.0, 1.0)
NO_INTERVAL = "no interval"


def _p(result: Any) -> float:
    return float(result.pvalue)


def read_differences(d: Sequence[float], margin: float, alpha: float = ALPHA) -> dict[str, Any]:
    """The tests on per-layout differences d (n,) float, A - B in the metric's units, against
    +-margin: {"layouts", "difference", "sd", "low", "high", "p_a_better", "p_b_better",
    "tost_p", "equivalent", "needed_difference", "needed_equivalence", "needed", "reading",
    "why"}. reading is one of :data:`READINGS`, or None when a value is NaN; why says what
    limited the reading (None when the tests ran as usual); needed the layouts that would
    decide an inconclusive reading (rounded up), else None."""
    x = np.asarray(d, dtype=float)
    n = int(x.size)
    out: dict[str, Any] = dict.fromkeys(
        ("difference", "sd", "low", "high", "p_a_better", "p_b_better", "tost_p",
         "needed_difference", "needed_equivalence", "needed", "reading", "why"))  # fmt: skip
    out |= {"layouts": n, "margin": margin, "equivalent": None}
    if n and not np.isfinite(x).all():
        out["why"] = f"no reading: {int((~np.isfinite(x)).sum())} of {n} layouts have no value"
        return out
    if n < MIN_LAYOUTS:
        out["reading"] = "inconclusive"
        out["why"] = (
            f"{n} layout{'s' * (n != 1)}: a test paired by layout needs {MIN_LAYOUTS} or more"
        )
        if n:
            out["difference"] = float(x[0])
        return out
    mean, sd = mean_sd(x)
    out |= {"difference": mean, "sd": sd}
    if sd == 0:  # the t statistic is +-inf (or 0/0): its limit
        out |= {"low": mean, "high": mean, "why": f"no spread: every layout differs by {mean:.4g}",
                "p_a_better": 0.0 if mean > 0 else 1.0, "p_b_better": 0.0 if mean < 0 else 1.0,
                "tost_p": 0.0 if abs(mean) < margin else 1.0}  # fmt: skip
    else:
        test = stats.ttest_1samp(x, 0.0)
        interval = test.confidence_interval(1 - alpha)
        out |= {**_bounded(float(interval.low), float(interval.high), n),
                "p_a_better": _p(stats.ttest_1samp(x, 0.0, alternative="greater")),
                "p_b_better": _p(stats.ttest_1samp(x, 0.0, alternative="less")),
                "tost_p": max(_p(stats.ttest_1samp(x, -margin, alternative="greater")),
                              _p(stats.ttest_1samp(x, margin, alternative="less")))}  # fmt: skip
    out["equivalent"] = out["tost_p"] < alpha
    out["reading"] = reading_rule(out["p_a_better"], out["p_b_better"], out["tost_p"], alpha)
    if out["reading"] == "inconclusive":
        diff = layouts_for_difference(mean, sd, alpha / 2, POWER)
        equiv = layouts_for_equivalence(mean, sd, margin, alpha, POWER)
        out |= {"needed_difference": _whole(diff), "needed_equivalence": _whole(equiv),
                "needed": _whole(min(diff, equiv))}  # fmt: skip
    return out


def reading_rule(p_a_better: float, p_b_better: float, tost_p: float, alpha: float = ALPHA) -> str:
    """The reading, one of :data:`READINGS`, from the one-sided p-values of A > B and B > A
    and TOST's p: a direction when its test rejects at alpha / 2, else equivalence when TOST
    rejects at alpha, else inconclusive. The one home of the rule: every reading (these
    policies, the recipe, Holm-adjusted) passes through it."""
    if p_a_better < alpha / 2:
        return "A better"
    if p_b_better < alpha / 2:
        return "B better"
    return "equivalent" if tost_p < alpha else "inconclusive"


def _bounded(low: float, high: float, n: int) -> dict[str, Any]:
    """{"low", "high"} of a t interval kept inside what a difference can be
    (:data:`DIFFERENCE_RANGE`); both None, and "why" said, when it spans the whole range, as
    it does on a handful of layouts (two layouts: t = 12.7): such an interval says nothing
    (docs/design/cli-output.md#compare-groups-intervals-single-layouts)."""
    lo, hi = DIFFERENCE_RANGE
    if low <= lo and high >= hi:
        return {"low": None, "high": None,
                "why": f"{NO_INTERVAL}: on {n} layouts the 95 % t interval spans every possible "
                "difference"}  # fmt: skip
    return {"low": max(low, lo), "high": min(high, hi)}


def _whole(n: float) -> int | None:
    """A planned count of layouts, rounded up, at least MIN_LAYOUTS (None for never)."""
    return None if math.isinf(n) else max(MIN_LAYOUTS, math.ceil(n - 1e-9))


def reading_of(scores: Mapping[Unit, tuple[float, float]], margin: float) -> dict[str, Any]:
    """:func:`read_differences` on paired scores ({layout unit: (A, B)}), with each side's
    mean over the layouts ("mean_a", "mean_b")."""
    pairs = np.array(list(scores.values()), dtype=float).reshape(-1, 2)
    out = read_differences(pairs[:, 0] - pairs[:, 1], margin)
    means = pairs.mean(axis=0) if len(pairs) else (None, None)
    return out | {
        "mean_a": None if means[0] is None else float(means[0]),
        "mean_b": None if means[1] is None else float(means[1]),
    }


def plan_of(
    scores: Mapping[Unit, tuple[float, float]], margin: float, alpha: float = ALPHA
) -> dict[str, Any]:
    """A power plan from a pilot's paired scores ({layout unit: (A, B)}): {"layouts" (in the
    pilot), "difference", "sd", "needed_difference", "needed_equivalence" (layouts for 80 %
    power, rounded up; None for never), "needed" (the fewer), "aim" (the reading the plan
    aims at: 'A better', 'B better' or 'equivalent'; None when no plan can be made), "why"}.
    The observed mean and sd are taken as the truth: a planning figure, not a test."""
    pairs = np.array(list(scores.values()), dtype=float).reshape(-1, 2)
    d = pairs[:, 0] - pairs[:, 1]
    out: dict[str, Any] = {"layouts": int(d.size), "margin": margin, "difference": None,
                           "sd": None, "needed_difference": None, "needed_equivalence": None,
                           "needed": None, "aim": None, "why": None}  # fmt: skip
    if d.size and not np.isfinite(d).all():
        out["why"] = f"no plan: {int((~np.isfinite(d)).sum())} of {d.size} layouts have no value"
        return out
    if d.size < MIN_LAYOUTS:
        out["why"] = f"no plan: a pilot needs {MIN_LAYOUTS} layouts or more to show a spread"
        return out
    mean, sd = mean_sd(d)
    diff = layouts_for_difference(mean, sd, alpha / 2, POWER)
    equiv = layouts_for_equivalence(mean, sd, margin, alpha, POWER)
    aim = "equivalent" if equiv <= diff else ("A better" if mean > 0 else "B better")
    return out | {"difference": mean, "sd": sd, "needed_difference": _whole(diff),
                  "needed_equivalence": _whole(equiv), "needed": _whole(min(diff, equiv)),
                  "aim": aim}  # fmt: skip


def missing_metric(rows: Sequence[Row], metric: str) -> int:
    """How many rows have no value of metric (results from before the score)."""
    return sum(metric_value(r, metric) is None for r in rows)


def readings_by_group(
    rows: Sequence[Row],
    a: str,
    b: str,
    group_of: Mapping[Unit, Sequence[str]],
    margins: Mapping[str, float],
) -> dict[str, dict[str, dict[str, Any]]]:
    """{group: {metric: reading}} for each metric of margins (its margin), paired by layout
    (units (layout, noise, None)); group_of: each such unit's groups; "all" holds every unit.
    A metric some row of A or B lacks reads {"reading": None, "why": NO_SCORE, ...}."""
    mine = [r for r in rows if r["method"] in (a, b)]
    out: dict[str, dict[str, dict[str, Any]]] = defaultdict(dict)
    for metric, margin in margins.items():
        missing = missing_metric(mine, metric)
        groups: dict[str, dict[Unit, tuple[float, float]]] = defaultdict(dict)
        for u, s in paired_scores(mine, a, b, by_seed=False, metric=metric).items():
            for g in [*group_of.get(u, ()), "all"]:
                groups[g][u] = s
        for g, scores in groups.items():
            if missing:
                out[g][metric] = {"metric": metric, "margin": margin, "layouts": len(scores),
                                  "reading": None, "why": NO_SCORE, "rows_without": missing}  # fmt: skip
            else:
                out[g][metric] = {"metric": metric} | reading_of(scores, margin)
    return dict(out)


def reading_text(record: Mapping[str, Any]) -> str:
    """The reading of a record of :func:`readings_by_group` in words, one of: 'A better',
    'B better' (each with '; also within ±δ' when TOST agrees), 'equivalent within ±δ',
    'inconclusive (about N layouts would decide)', 'inconclusive (<why>)', or why there is
    no reading."""
    reading, why = record.get("reading"), record.get("why")
    if reading is None:
        return str(why)
    within = margin_text(record["metric"], record["margin"])
    # no spread, or no interval: said beside the reading, short (the record keeps the whole)
    said = f" ({str(why).partition(':')[0]})" if why else ""
    if reading in ("A better", "B better"):
        return reading + (f"; also within {within}" if record["equivalent"] else "") + said
    if reading == "equivalent":
        return f"equivalent within {within}{said}"
    if record.get("needed") is None:
        return f"inconclusive ({why})"
    return f"inconclusive (about {record['needed']} layouts would decide)"


def metric_text(metric: str, x: float | None, signed: bool = False) -> str:
    """A metric's value as printed: success in points (%), a score to three decimals."""
    if x is None:
        return "--"
    sign = "+" if signed else ""
    return f"{100 * x:{sign}.1f}" if metric == "success" else f"{x:{sign}.3f}"


def readings_table(
    readings: Mapping[str, Mapping[str, Mapping[str, Any]]],
    trained_on: Mapping[str, str] | None = None,
) -> str:
    """The records of :func:`readings_by_group` as Markdown, one line per (group, metric) in
    their order: each side's mean, A - B with its 95 % interval (success in points), the
    smaller one-sided p with its direction, TOST's p against the margin, the reading; columns
    that do not fit the page's width in a second table (``page_width.split_columns``).
    trained_on: group -> how many of its worlds a side trained on (``k of n``, '' for none),
    given when some group holds training worlds: a column after the metric, so the flagged
    group, kept in every part of a split table, stays short (``training_worlds``)."""
    header = ["tasks", "metric (margin)", "layouts", "A", "B", "A - B [95 % interval]",
              "p one-sided", "TOST p", "reading"]  # fmt: skip
    align = ["---", "---", RIGHT, RIGHT, RIGHT, "---", RIGHT, RIGHT, "---"]
    if trained_on:
        header.insert(2, "trained on")
        align.insert(2, "---")
    body = []
    for group, per in readings.items():
        for metric, r in per.items():
            m = f"{metric} ({margin_text(metric, r['margin'])})"
            diff, p, tost = "--", "--", "--"
            if r.get("difference") is not None:
                diff = metric_text(metric, r["difference"], True)
            if r.get("low") is not None:
                low, high = (metric_text(metric, r[k], True) for k in ("low", "high"))
                diff += f" [{low}, {high}]"
            elif str(r.get("why")).startswith(NO_INTERVAL):
                diff += f" ({NO_INTERVAL} on {r['layouts']} layouts)"
            if r.get("p_a_better") is not None:
                a_side = r["p_a_better"] <= r["p_b_better"]
                p = f"{min(r['p_a_better'], r['p_b_better']):.3g} ({'A > B' if a_side else 'B > A'})"
                tost = f"{r['tost_p']:.3g}"
            means = [metric_text(metric, r.get(k)) for k in ("mean_a", "mean_b")]
            body.append([group, m, str(r["layouts"]), *means, diff, p, tost, reading_text(r)])
            if trained_on:
                body[-1].insert(2, trained_on.get(group, ""))
    return split_columns(header, align, body, keys=2)
