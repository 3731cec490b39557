"""The recipe-level reading: A - B with the training seed a random effect (docs/design/readings-recipe.md).

Today's reading (:mod:`~d3dwa_bullet.evaluation.readings`) answers "these policies": each side
averaged over its training seeds on a layout, the interval carrying only the layout-to-layout
spread. The recipe asks what another draw of training seeds would give. The data of one side is
a (seeds x layouts) table of per-cell means (a cell: one training seed on one layout, averaged
over its evaluation seeds); a fixed side (a DWA, a held random chooser) has one row and no seed
variance. Every seed of both sides shares the layouts (a crossed design), and the model is

    y_X[s, l] = mu_X + seed_X[s] + layout_X[l] + e_X[s, l]

with seeds, layouts and residuals (the seed x layout interaction with the episode's own noise)
random and independent. The estimate is the difference of grand means; its variance is

    V = sigma2_seed_A / S_A + sigma2_seed_B / S_B + E[s_d^2] / L

where s_d^2 is the sample variance over layouts of the seed-averaged difference d_l (today's
reading's spread, which already holds each side's residual / S). Each seed variance comes from
the balanced two-way ANOVA by method of moments: var_s(row means) - MS_interaction / L. The
seeds' share of V (both sides together) is floored at 0, so the recipe's standard error is never
below today's. V's mean squares are independent under normality, so its degrees of freedom are
Satterthwaite's. With no seed share the reading is today's paired t; with a large one it tends
to the t on per-seed means.

:func:`recipe_estimate` returns (mean, se, df) as plain numbers; :func:`read_estimate` reads any
(mean, se, df) with :func:`readings.reading_rule`, the one home of the four readings. The array
functions take leading batch axes, so a simulation of thousands of replicates is one call.
Pure: numpy and SciPy, no simulator, no torch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.paired import Row, metric_value
from d3dwa_bullet.evaluation.readings import ALPHA, read_differences, reading_rule

QUESTIONS = {
    "recipe": "the recipe (training seed random)",
    "policies": "these policies (training seeds fixed)",
}
"""What a reading answers, with its label: the recipe (the training seed a random effect) or these
policies (the trained seeds fixed). A plan's cells and the tables name one of these."""

RECIPE_WHY = "seeds and layouts to decide: recipe_sizing"
"""Why an inconclusive recipe-level reading names no N: it needs seeds as well as layouts."""


@dataclass(frozen=True)
class Estimate:
    """A - B (the metric's units), its standard error and degrees of freedom (inf: normal)."""

    mean: float
    se: float
    df: float


def _side_terms(y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One side's seed terms of V for y (..., S, L): (var of row means / S, its df S - 1,
    -MS_interaction / (L S), its df (S - 1)(L - 1)); zeros where S is 1 (a fixed side)."""
    s, n = y.shape[-2], y.shape[-1]
    if s < 2:
        zero = np.zeros(y.shape[:-2])
        return zero, zero + 1.0, zero, zero + 1.0
    rows = y.mean(axis=-1)
    cols = y.mean(axis=-2, keepdims=True)
    grand = rows.mean(axis=-1)
    resid = y - rows[..., None] - cols + grand[..., None, None]
    ms_int = (resid**2).sum(axis=(-2, -1)) / ((s - 1) * (n - 1))
    seed_term = rows.var(axis=-1, ddof=1) / s
    return seed_term, s - 1.0, -ms_int / (n * s), (s - 1.0) * (n - 1.0)


def recipe_arrays(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, se, df) of A - B at the recipe level for per-cell means a (..., S_A, L) and
    b (..., S_B, L) on the same L layouts (leading axes: replicates); a side with S = 1 is
    fixed (no seed variance). L >= 2. df is inf where se is 0."""
    if a.shape[-1] != b.shape[-1] or a.shape[-1] < 2:
        raise ValueError(f"both sides need the same 2+ layouts, got {a.shape} and {b.shape}")
    d = a.mean(axis=-2) - b.mean(axis=-2)
    n = d.shape[-1]
    layout_term = d.var(axis=-1, ddof=1) / n
    seeds = [*_pairs(_side_terms(a)), *_pairs(_side_terms(b))]
    keep = sum(t for t, _ in seeds) > 0  # the seeds' share of V, floored at 0: then today's t
    terms = [(layout_term, n - 1.0), *((np.where(keep, t, 0.0), k) for t, k in seeds)]
    v = sum(t for t, _ in terms)
    denom = sum(t**2 / k for t, k in terms)
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.where(denom > 0, v**2 / np.where(denom > 0, denom, 1.0), np.inf)
    return d.mean(axis=-1), np.sqrt(v), df


def _pairs(t: tuple[np.ndarray, ...]) -> list[tuple[np.ndarray, Any]]:
    return [(t[0], t[1]), (t[2], t[3])]


def policies_arrays(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, se, df) of today's reading ("these policies") on the same tables: the paired t on
    the seed-averaged per-layout differences, se = sd / sqrt(L), df = L - 1."""
    d = a.mean(axis=-2) - b.mean(axis=-2)
    n = d.shape[-1]
    return d.mean(axis=-1), d.std(axis=-1, ddof=1) / np.sqrt(n), np.full(d.shape[:-1], n - 1.0)


def recipe_estimate(a: np.ndarray, b: np.ndarray) -> Estimate:
    """The recipe-level A - B of one cell as plain numbers: a (S_A, L) and b (S_B, L) each
    side's per-cell means (rows: training seeds, one row for a fixed side; columns: the same
    layouts in the same order). The function a sequential look calls."""
    mean, se, df = recipe_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return Estimate(float(mean), float(se), float(df))


def read_estimate(est: Estimate, margin: float, alpha: float = ALPHA) -> dict[str, Any]:
    """An estimate read as :func:`readings.read_differences` reads its t: {"difference", "se",
    "df", "low", "high" (the 1 - alpha interval), "p_a_better", "p_b_better", "tost_p"
    (against +-margin), "equivalent", "reading", "why"}; se 0 takes the t-test's limit."""
    mean, se, df = est.mean, est.se, est.df
    out: dict[str, Any] = {"difference": mean, "se": se, "df": df, "margin": margin, "why": None}
    if not np.isfinite(mean) or not np.isfinite(se):
        return out | {"reading": None, "why": "no reading: a value is missing", "equivalent": None}
    if se == 0:
        out |= {"low": mean, "high": mean, "why": f"no spread: every value differs by {mean:.4g}",
                "p_a_better": 0.0 if mean > 0 else 1.0, "p_b_better": 0.0 if mean < 0 else 1.0,
                "tost_p": 0.0 if abs(mean) < margin else 1.0}  # fmt: skip
    else:
        t = stats.t(df)
        half = float(t.ppf(1 - alpha / 2)) * se
        out |= {"low": mean - half, "high": mean + half,
                "p_a_better": float(t.sf(mean / se)), "p_b_better": float(t.cdf(mean / se)),
                "tost_p": max(float(t.sf((mean + margin) / se)), float(t.cdf((mean - margin) / se)))}  # fmt: skip
    out["equivalent"] = out["tost_p"] < alpha
    out["reading"] = reading_rule(out["p_a_better"], out["p_b_better"], out["tost_p"], alpha)
    if out["reading"] == "inconclusive" and out["why"] is None:
        out["why"] = RECIPE_WHY
    return out


def training_seeds(rows: Sequence[Row], method: str) -> list[str]:
    """The training seeds of method's rows, sorted; [] for a fixed method (no policy_seed)."""
    seeds = {str(r.get("policy_seed")) for r in rows if r["method"] == method}
    return sorted(s for s in seeds if s not in ("", "None"))


def check_recipe_side(rows: Sequence[Row], method: str) -> list[str]:
    """method's training seeds; ResultsError (one line, naming the method and its seeds) when
    it is learned with fewer than two: a recipe-level reading needs a seed spread."""
    seeds = training_seeds(rows, method)
    if len(seeds) == 1:
        raise ResultsError(
            f"method {method!r} has one training seed ({seeds[0]}): a reading about the recipe "
            "needs two or more (read 'these policies' instead)"
        )
    return seeds


Cells = dict[tuple[str, str], float]
"""One side's per-cell means: (training seed, layout) -> the metric's mean; a fixed side's seed
is '' (or 'None'); a layout is a (world, noise), as in today's unit."""


def cell_means(rows: Sequence[Row], method: str, metric: str) -> Cells:
    """method's per-cell means of metric over the rows (a missing value is NaN)."""
    cells: dict[tuple[str, str], list[float]] = {}
    for r in rows:
        if r["method"] == method:
            v = metric_value(r, metric)
            key = (str(r.get("policy_seed")), f"{r['world']} ({r['noise']})")
            cells.setdefault(key, []).append(np.nan if v is None else v)
    return {k: float(np.mean(v)) for k, v in cells.items()}


def tables_of(ca: Cells, cb: Cells) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(A's table (S_A, L), B's table (S_B, L), the L layouts, sorted) over the layouts every
    seed of both sides ran; rows in the seeds' sorted order."""
    seeds = [sorted({s for s, _ in c}) for c in (ca, cb)]
    shared = None
    for c, mine in zip((ca, cb), seeds, strict=True):
        full = {w for _, w in c if all((s, w) in c for s in mine)}
        shared = full if shared is None else shared & full
    layouts = sorted(shared or ())
    ta, tb = (np.array([[c[(s, w)] for w in layouts] for s in mine], dtype=float).reshape(len(mine), len(layouts))
              for c, mine in zip((ca, cb), seeds, strict=True))  # fmt: skip
    return ta, tb, layouts


def seed_layout_tables(
    rows: Sequence[Row], a: str, b: str, metric: str
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """:func:`tables_of` the two sides' :func:`cell_means` in these rows."""
    return tables_of(cell_means(rows, a, metric), cell_means(rows, b, metric))


def learned(cells: Cells) -> bool:
    """Whether a side's cells carry training seeds (a learned method)."""
    return any(s not in ("", "None") for s, _ in cells)


def both_readings(
    rows: Sequence[Row], a: str, b: str, metric: str, margin: float
) -> dict[str, dict[str, Any]]:
    """:func:`read_cells` of one cell's rows under one profile. ResultsError naming a learned
    side with one training seed."""
    for m in (a, b):
        check_recipe_side(rows, m)
    return read_cells(cell_means(rows, a, metric), cell_means(rows, b, metric), metric, margin)


def read_cells(ca: Cells, cb: Cells, metric: str, margin: float) -> dict[str, dict[str, Any]]:
    """{"policies": record, "recipe": record} for one cell's per-cell means: each
    :func:`read_estimate`'s record (these policies': ``readings.read_differences``') with
    "metric", "layouts", "mean_a", "mean_b", "seeds_a", "seeds_b" (0 for a fixed side);
    "recipe" is absent when neither side is learned (no seed to be random)."""
    ta, tb, layouts = tables_of(ca, cb)
    n, is_learned = len(layouts), (learned(ca), learned(cb))
    base = {"metric": metric, "layouts": n, "seeds_a": ta.shape[0] * is_learned[0],
            "seeds_b": tb.shape[0] * is_learned[1], "needed": None,
            "mean_a": float(ta.mean()) if n else None, "mean_b": float(tb.mean()) if n else None}  # fmt: skip
    out: dict[str, dict[str, Any]] = {}
    for q in ("policies", "recipe") if any(is_learned) else ("policies",):
        if n < 2:
            out[q] = base | {"margin": margin, "reading": "inconclusive", "equivalent": None,
                             "difference": None, "why": f"{n} shared layouts: a reading needs 2 or more"}  # fmt: skip
            continue
        if q == "policies":  # today's reading, as `compare` takes it
            out[q] = base | read_differences(ta.mean(axis=0) - tb.mean(axis=0), margin)
        else:
            out[q] = base | read_estimate(recipe_estimate(ta, tb), margin)
    return out
