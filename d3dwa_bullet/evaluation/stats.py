"""Confidence intervals of episode outcomes: success rate (Wilson) and mean time (Student t).

Pure functions of counts and numbers (no simulator, no torch): the sweep's tables, plots and
``--json`` summaries are all computed from :class:`CellStats`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

CONFIDENCE = 0.95
Z95 = 1.959963984540054
"""Standard normal quantile of 0.975."""


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a success probability from k successes in n trials."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    # The interval contains p in exact arithmetic; at k = 0 or k = n rounding can put a bound
    # a few ulp on the wrong side of it (and make an error bar negative).
    return (min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half)))


def t_interval(
    values: Sequence[float], confidence: float = CONFIDENCE
) -> tuple[float, float, float]:
    """(mean, low, high): the Student t confidence interval of the mean (nan bounds if n < 2)."""
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return (math.nan, math.nan, math.nan)
    mean = float(x.mean())
    if x.size < 2:
        return (mean, math.nan, math.nan)
    from scipy.stats import t  # start-up cost: scipy.stats takes ~0.5 s, needed only here

    half = float(t.ppf(0.5 + confidence / 2, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    return (mean, mean - half, mean + half)


@dataclass(frozen=True)
class CellStats:
    """Success and time statistics of one group of episodes."""

    n: int
    successes: int
    rate: float
    rate_lo: float
    rate_hi: float
    time_mean: float
    """Mean time to goal over the successful episodes, s (nan if none)."""
    time_lo: float
    time_hi: float
    score_mean: float = math.nan
    """Mean episode score, robot form (docs/design/score.md#score); nan for rows without a score."""
    score_barn_mean: float = math.nan
    """Mean episode score, BARN's official form; nan for rows without a score."""

    @classmethod
    def of(cls, rows: Sequence[Mapping[str, Any]]) -> CellStats:
        """Stats of result rows (keys ``outcome``, ``time_s`` and, if scored, ``score`` and
        ``score_barn``, as in results.csv)."""
        times = [r["time_s"] for r in rows if r["outcome"] == "goal"]
        n, k = len(rows), len(times)
        lo, hi = wilson_interval(k, n)
        mean, tlo, thi = t_interval(times)
        scored = bool(rows) and all(r.get("score") is not None for r in rows)
        score, barn = (
            (float(np.mean([r[c] for r in rows])) for c in ("score", "score_barn"))
            if scored
            else (math.nan, math.nan)
        )
        return cls(n, k, k / n if n else math.nan, lo, hi, mean, tlo, thi, score, barn)


Series = dict[str, dict[str, list[tuple[Any, CellStats]]]]
"""layout group -> method -> [(x, stats)] (x a noise level or a profile name)."""


def group_series(
    groups: Mapping[tuple[str, str, Any], Sequence[Mapping[str, Any]]],
    layouts: Sequence[str],
    methods: Sequence[str],
    key: Callable[[Any], Any] | None = None,
) -> Series:
    """CellStats of rows grouped by (layout group, method, x): layout groups in the order of
    layouts, methods in the order of methods, xs sorted (by key); empty groups left out."""
    out: Series = {}
    for layout in layouts:
        per_method = {}
        for m in methods:
            xs = sorted((x for (g, mm, x) in groups if g == layout and mm == m), key=key)
            if xs:
                per_method[m] = [(x, CellStats.of(groups[(layout, m, x)])) for x in xs]
        if per_method:
            out[layout] = per_method
    return out
