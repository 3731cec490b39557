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
higher on these layouts than chance pairing would give (docs/design.md#paired-test).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from d3dwa_bullet.errors import ResultsError

Row = Mapping[str, Any]
Unit = tuple[str, str, int | None]
"""(layout, noise, evaluation seed); the seed None when the unit pools every evaluation seed."""
MIN_LAYOUTS = 2
"""Layouts two methods must share for a paired test: one layout is a single pair of scores."""


def unit_of(row: Row, by_seed: bool = True) -> Unit:
    """The unit of a results row: (layout, noise, evaluation seed), the seed None unless by_seed."""
    return (row["world"], row["noise"], int(row["seed"]) if by_seed else None)


def paired_scores(
    rows: Sequence[Row], a: str, b: str, by_seed: bool = True
) -> dict[Unit, tuple[float, float]]:
    """{unit: (A's success, B's success)} over the units both methods ran, each side's success
    averaged over its training seeds there (and over its evaluation seeds unless by_seed)."""
    seen: dict[Unit, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        if r["method"] in (a, b):
            seen[unit_of(r, by_seed)][r["method"]].append(r["outcome"] == "goal")
    return {
        u: (float(np.mean(per[a])), float(np.mean(per[b])))
        for u, per in sorted(seen.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2] or 0))
        if a in per and b in per
    }


def check_layouts(scores: Mapping[Unit, Any], a: str, b: str, where: str) -> None:
    """ResultsError (one line) unless the methods share MIN_LAYOUTS layouts or more."""
    layouts = sorted({u[0] for u in scores})
    if not layouts:
        raise ResultsError(f"{where}: methods {a!r} and {b!r} share no layout: nothing to pair")
    if len(layouts) < MIN_LAYOUTS:
        raise ResultsError(
            f"{where}: methods {a!r} and {b!r} share only one layout ({layouts[0]}); a test "
            f"paired by layout needs {MIN_LAYOUTS} or more"
        )


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
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    if mean <= 0:
        return float("inf")
    if sd == 0:
        return None
    z = stats.norm.ppf(1 - alpha) + stats.norm.ppf(power)
    return float((z * sd / mean) ** 2)
