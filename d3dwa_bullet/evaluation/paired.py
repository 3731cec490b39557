"""A test paired by layout: is A's success higher than B's on the same layouts?

P(A > B) (:func:`seed_tables.improvement`) says how likely a run of A beats a run of B on a
task, with an interval over runs (training seeds): an effect size. It treats the two sides'
runs as independent, although both ran on the same layouts. The paired test asks the other
question, with the layouts as the sample: a *unit* is one (layout, noise, evaluation seed) that
both methods ran; its score is each side's success there, averaged over its training seeds (a
fixed or reference method has one episode per unit). With several evaluation seeds their units
share a layout and are not independent; ``by_seed=False`` makes the unit (layout, noise), each
side's success averaged over its training and evaluation seeds there: fewer units, the
conservative test. The differences A - B over the units go
to the Wilcoxon signed-rank test (``scipy.stats.wilcoxon``, one-sided: A > B; units where the
two agree are dropped, ``zero_method="wilcox"``). A p-value below 0.05 says A's success is
higher on these layouts than chance pairing would give (docs/design/learning-protocol.md#paired-test).

The scores may be any per-episode metric of :data:`METRICS` (success, the score, BARN's
official score): :mod:`d3dwa_bullet.evaluation.readings` reads their mean difference as one of
four answers, and the power figures here (:func:`layouts_for_difference`,
:func:`layouts_for_equivalence`) say how many units would decide it.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import optimize, stats

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.repeats import repeats_at_every_seed

Row = Mapping[str, Any]
Unit = tuple[str, str, int | None]
"""(layout, noise, evaluation seed); the seed None when the unit pools every evaluation seed."""
MIN_LAYOUTS = 2
"""Layouts two methods must share for a paired test: one layout is a single pair of scores."""
METRICS = ("success", "score", "score_barn")
"""Per-episode metrics a test pairs: success (1 at the goal, else 0), the score scaled to the
robot and BARN's official score (both in [0, 1], 0 for a failure; None in rows of results
from before the score)."""


def metric_value(row: Row, metric: str) -> float | None:
    """A row's value of metric (one of :data:`METRICS`): None where the row has no score."""
    if metric == "success":
        return float(row["outcome"] == "goal")
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r} (one of {', '.join(METRICS)})")
    value = row.get(metric)
    return None if value is None or value == "" else float(value)


def unit_of(row: Row, by_seed: bool = True) -> Unit:
    """The unit of a results row: (layout, noise, evaluation seed), the seed None unless by_seed."""
    return (row["world"], row["noise"], int(row["seed"]) if by_seed else None)


def paired_scores(
    rows: Sequence[Row], a: str, b: str, by_seed: bool = True, metric: str = "success"
) -> dict[Unit, tuple[float, float]]:
    """{unit: (A's metric, B's metric)} over the units both methods ran, each side's value
    averaged over its training seeds there (and over its evaluation seeds unless by_seed).
    A side with a row lacking the metric (None) is NaN there: never averaged over fewer. An
    episode that repeats at every evaluation seed (:mod:`~d3dwa_bullet.evaluation.repeats`),
    run once, by seed stands for each evaluation seed the other side ran on its layout: the
    units and values are those its repeated rows gave (and give, if rows hold them)."""
    seen: dict[Unit, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    once: dict[tuple[str, str], dict[str, list[tuple[int, float]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    for r in (r for r in rows if r["method"] in (a, b)):
        value = np.nan if (v := metric_value(r, metric)) is None else v
        if by_seed and repeats_at_every_seed(r["method"], r["noise"]):
            once[(r["world"], r["noise"])][r["method"]].append((int(r["seed"]), value))
        else:
            seen[unit_of(r, by_seed)][r["method"]].append(value)
    # an episode run once for every evaluation seed stands at each seed the other side ran
    # there; two such sides pair once, at their first seed
    at: dict[tuple[str, str], list[Unit]] = defaultdict(list)
    for u in seen:
        at[u[:2]].append(u)  # type: ignore[arg-type]
    for (world, noise), per in once.items():
        first = min(seed for runs in per.values() for seed, _ in runs)
        for method, runs in per.items():
            for u in at.get((world, noise)) or [(world, noise, first)]:
                seen[u][method] += [value for _, value in runs]
    return {
        u: (float(np.mean(per[a])), float(np.mean(per[b])))
        for u, per in sorted(seen.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2] or 0))
        if a in per and b in per
    }


def check_layouts(scores: Mapping[Unit, Any], a: str, b: str, where: str) -> str | None:
    """ResultsError (one line) when the methods share no layout; with one shared layout, the
    line that says why no paired test is given (None with MIN_LAYOUTS layouts or more)."""
    layouts = sorted({u[0] for u in scores})
    if not layouts:
        raise ResultsError(f"{where}: methods {a!r} and {b!r} share no layout: nothing to pair")
    if len(layouts) < MIN_LAYOUTS:
        return (
            f"No paired test: methods {a!r} and {b!r} share only one layout ({layouts[0]}); a "
            f"test paired by layout needs {MIN_LAYOUTS} or more."
        )
    return None


def paired_test(scores: Mapping[Unit, tuple[float, float]]) -> dict[str, Any]:
    """{"units", "wins", "losses", "ties", "p"}: the one-sided Wilcoxon signed-rank p-value
    of A > B over the units (1.0 when no unit differs: no evidence that A is higher; None
    for fewer than two units)."""
    d = np.array([sa - sb for sa, sb in scores.values()], dtype=float)
    out: dict[str, Any] = {
        "units": int(d.size), "wins": int((d > 0).sum()), "losses": int((d < 0).sum()),
        "ties": int((d == 0).sum()), "p": None,
    }  # fmt: skip
    if d.size < 2:
        return out
    if not d.any():
        out["p"] = 1.0
        return out
    out["p"] = float(stats.wilcoxon(d, alternative="greater", zero_method="wilcox").pvalue)
    return out


def paired_by_group(
    rows: Sequence[Row],
    a: str,
    b: str,
    group_of: Mapping[Unit, Sequence[str]],
    by_seed: bool = True,
) -> dict[str, dict[str, Any]]:
    """:func:`paired_test` per group name (group_of: each unit's groups, units as
    :func:`unit_of` makes them) and for "all"."""
    scores = paired_scores(rows, a, b, by_seed)
    groups: dict[str, dict[Unit, tuple[float, float]]] = defaultdict(dict)
    for u, s in scores.items():
        for g in [*group_of.get(u, ()), "all"]:
            groups[g][u] = s
    return {g: paired_test(s) for g, s in groups.items()}


FLOAT_NOISE = 1e-9
"""Relative size below which a spread of per-unit differences is rounding, not spread."""


def mean_sd(d: np.ndarray) -> tuple[float, float]:
    """The mean and sample sd (ddof 1) of differences d (n >= 2,), the sd 0.0 when it is below
    :data:`FLOAT_NOISE` times the largest |d| (at least 1): differences equal but for rounding
    (0.8 - 0.6 and 1.0 - 0.8) have no spread, and a t statistic on them would be noise."""
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    if sd <= FLOAT_NOISE * max(1.0, float(np.abs(d).max())):
        sd = 0.0
    return mean, sd


def units_for_power(
    scores: Mapping[Unit, tuple[float, float]], alpha: float = 0.05, power: float = 0.8
) -> float | None:
    """How many units (layouts) a one-sided paired test at ``alpha`` needs to find A > B with
    probability ``power``, if the mean and spread of the per-unit differences A - B were what
    these units show: ((z_alpha + z_power) sd / mean)^2, the normal approximation (the
    signed-rank test's efficiency against it is at least 0.86). inf when A is not ahead on
    average; None for fewer than two units or no spread. A planning figure for a yardstick,
    not a test: it takes the observed effect as the true one."""
    d = np.array([sa - sb for sa, sb in scores.values()], dtype=float)
    if d.size < 2:
        return None
    mean, sd = mean_sd(d)
    if mean <= 0:
        return float("inf")
    if sd == 0:
        return None
    return layouts_for_difference(mean, sd, alpha, power)


def layouts_for_difference(mean: float, sd: float, alpha: float, power: float = 0.8) -> float:
    """Units a one-sided paired test at ``alpha``, in the direction of ``mean``, needs to find
    the difference with probability ``power`` if the per-unit differences had this mean and
    sd (any metric, its own units): ((z_alpha + z_power) sd / |mean|)^2, the normal
    approximation. inf for a zero mean; 0 for no spread (every unit already decides)."""
    if mean == 0:
        return float("inf")
    z = stats.norm.ppf(1 - alpha) + stats.norm.ppf(power)
    return float((z * sd / abs(mean)) ** 2)


def equivalence_power(n: float, mean: float, sd: float, margin: float, alpha: float) -> float:
    """The probability that a TOST at ``alpha`` against +-margin finds equivalence on n units
    whose differences have this mean and sd, by the normal approximation:
    Phi(sqrt(n) (margin - mean) / sd - z) + Phi(sqrt(n) (margin + mean) / sd - z) - 1, z the
    one-sided quantile of alpha (at least 0)."""
    z, root = stats.norm.ppf(1 - alpha), np.sqrt(n) / sd
    upper = stats.norm.cdf(root * (margin - mean) - z)
    lower = stats.norm.cdf(root * (margin + mean) - z)
    return float(max(upper + lower - 1.0, 0.0))


def layouts_for_equivalence(
    mean: float, sd: float, margin: float, alpha: float, power: float = 0.8
) -> float:
    """Units a TOST at ``alpha`` against +-margin needs to find equivalence with probability
    ``power`` if the per-unit differences had this mean and sd (:func:`equivalence_power`
    solved for n; a real number, round up). inf when |mean| >= margin (no yardstick shows
    equivalence then); 0 for no spread inside the margin."""
    if abs(mean) >= margin:
        return float("inf")
    if sd == 0:
        return 0.0
    # one side alone needs this many; the other side's shortfall only adds to it
    n = ((stats.norm.ppf(1 - alpha) + stats.norm.ppf(power)) * sd / (margin - abs(mean))) ** 2
    high = 2.0 * n + 2.0
    while equivalence_power(high, mean, sd, margin, alpha) < power:
        high *= 2.0
    return float(
        optimize.brentq(
            lambda k: equivalence_power(k, mean, sd, margin, alpha) - power, n, high, xtol=1e-6
        )
    )
