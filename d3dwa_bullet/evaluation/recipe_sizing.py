"""Sizing a recipe-level cell: the cheapest (training seeds, layouts) that reads it at 80 % power.

From a pilot's (seeds x layouts) tables of one cell (:func:`recipe.seed_layout_tables`), the
variance components of the crossed model of :mod:`~d3dwa_bullet.evaluation.recipe`, by the
same method of moments (each truncated at 0):

- ``seed_a``, ``seed_b``: each learned side's seed variance, var(row means) - MS_int / L;
- ``resid_a``, ``resid_b``: each learned side's residual (seed x layout with the episode's
  noise), MS_int;
- ``layout``: the layout variance of the difference that no seed average removes,
  s_d^2 - MS_int_A / S_A - MS_int_B / S_B (a fixed side's own episode noise is part of it).

At S seeds a learned side and L layouts the estimate's variance is

    V(S, L) = sum over learned sides (seed + resid / L) / S + layout / L

and its degrees of freedom are Satterthwaite's on the expected mean squares. The observed
mean difference is taken as the truth (a planning figure, as ``readings.plan_of``): the aim
is the difference (the direction's one-sided test at ALPHA / 2) or equivalence (TOST at ALPHA
against the margin), whichever is cheaper, each by the shifted-t approximation of its power.
The cost of a design is its training, learned sides x S x a seed's minutes, plus its episodes,
L x (learned sides x S + fixed sides) x an episode's seconds (docs/design/readings-recipe.md).
Pure: numpy and SciPy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import stats

from d3dwa_bullet.evaluation.readings import ALPHA, POWER


@dataclass(frozen=True)
class Components:
    """A cell's variance components (the metric's units squared), its observed A - B, the
    learned sides (0, 1 or 2) and the fixed ones."""

    difference: float
    seed_a: float
    seed_b: float
    resid_a: float
    resid_b: float
    layout: float
    learned: int
    fixed: int

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _side(y: np.ndarray) -> tuple[float, float]:
    """(seed variance, residual variance) of one side's (S, L) table; (0, 0) for S = 1."""
    s, n = y.shape
    if s < 2:
        return 0.0, 0.0
    rows, cols = y.mean(axis=1), y.mean(axis=0)
    resid = y - rows[:, None] - cols[None, :] + y.mean()
    ms_int = float((resid**2).sum() / ((s - 1) * (n - 1)))
    return max(0.0, float(rows.var(ddof=1)) - ms_int / n), ms_int


def components(a: np.ndarray, b: np.ndarray) -> Components:
    """The components of a cell from each side's (S, L) table of per-cell means (a fixed side:
    one row), the same L >= 2 layouts in the same order."""
    (sa, ra), (sb, rb) = _side(np.asarray(a, float)), _side(np.asarray(b, float))
    d = a.mean(axis=0) - b.mean(axis=0)
    layout = float(d.var(ddof=1)) - ra / a.shape[0] - rb / b.shape[0]
    learned = int(a.shape[0] > 1) + int(b.shape[0] > 1)
    return Components(float(d.mean()), sa, sb, ra, rb, max(0.0, layout), learned, 2 - learned)


def design_se_df(c: Components, seeds: int, layouts: Any) -> tuple[Any, Any]:
    """(se, Satterthwaite df) of the recipe's estimate at `seeds` a learned side and `layouts`
    (a number or an array of them), on the expected mean squares of c."""
    n = np.asarray(layouts, dtype=float)
    terms = [((c.layout + (c.resid_a + c.resid_b) / seeds) / n, n - 1.0)]
    for seed, resid in ((c.seed_a, c.resid_a), (c.seed_b, c.resid_b)):
        if seed > 0 or resid > 0:
            terms += [((seed + resid / n) / seeds, np.full_like(n, seeds - 1.0)),
                      (-resid / (n * seeds), (seeds - 1.0) * (n - 1.0))]  # fmt: skip
    v = np.maximum(sum(t for t, _ in terms), 0.0)
    denom = sum(t * t / k for t, k in terms)
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.where(denom > 0, v * v / np.where(denom > 0, denom, 1.0), np.inf)
    return np.sqrt(v), df


def power(
    c: Components, seeds: int, layouts: Any, aim: str, margin: float, alpha: float = ALPHA
) -> Any:
    """The power of a (seeds, layouts) design (layouts a number or an array) to read aim
    ("difference" or "equivalence") if c's observed difference were the truth (shifted-t
    approximation)."""
    se, df = design_se_df(c, seeds, layouts)
    delta = abs(c.difference)
    with np.errstate(divide="ignore", invalid="ignore"):
        if aim == "difference":
            out = stats.t.cdf(delta / se - stats.t.ppf(1 - alpha / 2, df), df)
            limit = float(delta > 0)
        else:
            q = stats.t.ppf(1 - alpha, df)
            out = np.maximum(
                0.0,
                stats.t.cdf((margin - delta) / se - q, df)
                + stats.t.cdf((margin + delta) / se - q, df)
                - 1,
            )
            limit = float(delta < margin)
    out = np.where(se > 0, out, limit)
    return float(out) if np.ndim(out) == 0 else out


def cost_seconds(
    c: Components, seeds: int, layouts: int, train_minutes: float, episode_seconds: float
) -> float:
    """A design's cost in seconds: its training plus its episodes (see the module's text)."""
    runs = c.learned * seeds + c.fixed
    return c.learned * seeds * train_minutes * 60.0 + layouts * runs * episode_seconds


def _fewest_layouts(c: Components, seeds: int, aim: str, margin: float, most: int) -> int | None:
    """The fewest layouts (>= 2) reaching POWER at `seeds`, or None within `most`: the first
    of a geometric grid that does, then every count in the gap before it (vectorised)."""
    grid = np.unique(np.geomspace(2, most, 300).round().astype(int))
    ok = np.flatnonzero(power(c, seeds, grid, aim, margin) >= POWER)
    if not ok.size:
        return None
    first = int(ok[0])
    low = 2 if first == 0 else int(grid[first - 1]) + 1
    span = np.arange(low, int(grid[first]) + 1)
    return int(span[np.flatnonzero(power(c, seeds, span, aim, margin) >= POWER)[0]])


def cheapest(
    c: Components,
    margin: float,
    train_minutes: float,
    episode_seconds: float,
    most_seeds: int = 50,
    most_layouts: int = 100_000,
) -> dict[str, Any]:
    """The cheapest design reading c at POWER: {"aim", "seeds", "layouts", "power", "hours"}
    (seeds a learned side; None for a cell without learned side), or {"why"} when no design
    within most_seeds and most_layouts reads it (e.g. a true difference of 0 and no margin)."""
    best: dict[str, Any] | None = None
    for aim in ("difference", "equivalence"):
        for seeds in range(2, most_seeds + 1) if c.learned else (1,):
            if best is not None and cost_seconds(c, seeds, 0, train_minutes, 0.0) >= best["cost"]:
                break  # training alone costs more from here on
            layouts = _fewest_layouts(c, seeds, aim, margin, most_layouts)
            if layouts is None:
                continue
            cost = cost_seconds(c, seeds, layouts, train_minutes, episode_seconds)
            if best is None or cost < best["cost"]:
                best = {"aim": aim, "seeds": seeds if c.learned else None, "layouts": layouts,
                        "power": power(c, seeds, layouts, aim, margin), "cost": cost}  # fmt: skip
    if best is None:
        return {"why": f"no design within {most_seeds} seeds and {most_layouts:,} layouts reaches "
                       f"{POWER:.0%} power"}  # fmt: skip
    return best | {"hours": best.pop("cost") / 3600.0}
