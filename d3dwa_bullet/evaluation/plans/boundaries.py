"""Group-sequential boundaries: Lan-DeMets O'Brien-Fleming alpha spending, one-sided.

A one-sided test at level ``alpha`` looked at K times, at information fractions
0 < t_1 < ... < t_K = 1 (layouts read over the maximum), spends
alpha(t) = 2 - 2 Phi(z_{1 - alpha/2} / sqrt(t)) (Lan & DeMets 1983, the O'Brien-Fleming-like
function): almost nothing early, alpha(1) = alpha at the maximum, so the last look spends all
of it. Boundary c_k is the z such that the chance, with no effect, of crossing first at look k
is alpha(t_k) - alpha(t_{k-1}). The z statistics of the looks are those of a Brownian motion,
corr(Z_j, Z_k) = sqrt(t_j / t_k), and the chance is found by the recursive numerical
integration of Armitage, McPherson & Rowe (1969): the density of Z_k on the region not yet
crossed is carried from look to look on a grid (:func:`boundaries`). The same recursion with a
drift gives a design's power (:func:`crossing_probability`) and so its maximum for a power
(:func:`drift_for_power`).

The difference test is two such tests, each way at alpha / 2; TOST is two at alpha each
(docs/design/sequential-plans.md). Pure: numpy and SciPy, no simulator.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import optimize, stats

Fractions = Sequence[float] | np.ndarray
"""Information fractions (K,), or boundaries (K,): a list or an array."""
GRID_STEP = 0.02
"""Spacing of the z grid the recursion integrates on (the trapezoid rule)."""
GRID_LOW = -9.0
"""Where the grid starts: the density below is negligible (Phi(-9) ~ 1e-19)."""


def spending(t: np.ndarray | float, alpha: float) -> np.ndarray:
    """Lan-DeMets O'Brien-Fleming alpha spent by information fraction t (in (0, 1]), one-sided
    level alpha: 2 - 2 Phi(z_{1 - alpha/2} / sqrt(t))."""
    z = stats.norm.ppf(1 - alpha / 2)
    return np.asarray(2 * stats.norm.sf(z / np.sqrt(np.asarray(t, dtype=float))))


def check_fractions(fractions: Fractions) -> np.ndarray:
    """fractions as a (K,) array; ValueError unless they increase within (0, 1]."""
    t = np.asarray(fractions, dtype=float)
    if t.size == 0 or not (np.all(np.diff(t) > 0) and t[0] > 0 and t[-1] <= 1 + 1e-12):
        raise ValueError(f"information fractions must increase within (0, 1], got {list(t)}")
    return t


def carry_density(
    density: np.ndarray, z: np.ndarray, t0: float, t1: float, grid: np.ndarray, drift: float
) -> np.ndarray:
    """The (sub-)density of Z at fraction t1 on grid, from its density on z at fraction t0
    (trapezoid weights folded in): Z_1 | Z_0 = z ~ N(z sqrt(t0/t1) + drift (t1 - t0)/sqrt(t1),
    (t1 - t0) / t1)."""
    sd = np.sqrt((t1 - t0) / t1)
    mean = z * np.sqrt(t0 / t1) + drift * (t1 - t0) / np.sqrt(t1)
    x = (grid[:, None] - mean[None, :]) / sd
    return (np.exp(-0.5 * x * x) @ density) / (sd * np.sqrt(2 * np.pi))


def trapezoid_weights(z: np.ndarray) -> np.ndarray:
    """(n,) the trapezoid rule's weights on an equally spaced grid z (n,)."""
    w = np.full(z.size, z[1] - z[0] if z.size > 1 else 1.0)
    w[0] = w[-1] = w[0] / 2
    return w


def grid_to(top: float) -> np.ndarray:
    """The z grid (n,) the recursion integrates on, from GRID_LOW up to a bound ``top``."""
    n = max(int(np.ceil((top - GRID_LOW) / GRID_STEP)), 2)
    return np.linspace(GRID_LOW, top, n + 1)


def crossing_probability(bounds: Fractions, fractions: Fractions, drift: float = 0.0) -> np.ndarray:
    """(K,) the chance of crossing upper boundary ``bounds`` first at each look, for a z
    statistic whose mean at fraction t is drift * sqrt(t) (drift 0: no effect; drift: the
    z the effect would have at the maximum)."""
    t = check_fractions(fractions)
    c = np.asarray(bounds, dtype=float)
    out = np.empty(t.size)
    out[0] = stats.norm.sf(c[0] - drift * np.sqrt(t[0]))
    z = grid_to(c[0])
    density = stats.norm.pdf(z - drift * np.sqrt(t[0])) * trapezoid_weights(z)
    for k in range(1, t.size):
        sd = np.sqrt((t[k] - t[k - 1]) / t[k])
        mean = z * np.sqrt(t[k - 1] / t[k]) + drift * (t[k] - t[k - 1]) / np.sqrt(t[k])
        out[k] = float(stats.norm.sf((c[k] - mean) / sd) @ density)
        grid = grid_to(c[k])
        density = carry_density(density, z, t[k - 1], t[k], grid, drift) * trapezoid_weights(grid)
        z = grid
    return out


def boundaries(fractions: Fractions, alpha: float) -> np.ndarray:
    """(K,) the upper z boundaries of a one-sided test at level alpha with Lan-DeMets
    O'Brien-Fleming spending at these information fractions (the last spends what the
    spending function has left at it: all of alpha when it is 1). Each look's boundary
    depends only on the looks up to it, so a plan's boundaries stay put as looks are added."""
    t = check_fractions(fractions)
    spent = np.diff(np.concatenate([[0.0], spending(t, alpha)]))
    c = np.empty(t.size)
    c[0] = stats.norm.isf(spent[0])
    z = grid_to(c[0])
    density = stats.norm.pdf(z) * trapezoid_weights(z)
    for k in range(1, t.size):
        sd = np.sqrt((t[k] - t[k - 1]) / t[k])
        mean = z * np.sqrt(t[k - 1] / t[k])

        def excess(
            ck: float, mean: np.ndarray = mean, sd: float = sd, f: np.ndarray = density, k: int = k
        ) -> float:
            return float(stats.norm.sf((ck - mean) / sd) @ f) - spent[k]

        c[k] = optimize.brentq(excess, -10.0, 40.0, xtol=1e-10)
        grid = grid_to(c[k])
        density = carry_density(density, z, t[k - 1], t[k], grid, 0.0) * trapezoid_weights(grid)
        z = grid
    return c


def drift_for_power(fractions: Fractions, alpha: float, power: float) -> float:
    """The drift (the z an effect has at the maximum) at which the one-sided sequential test
    at level alpha crosses by the last look with probability ``power``: the maximum's layouts
    for an effect delta with per-layout sd sigma are (drift sigma / delta)^2."""
    c = boundaries(fractions, alpha)

    def short(drift: float) -> float:
        return float(crossing_probability(c, fractions, drift).sum()) - power

    fixed = stats.norm.ppf(1 - alpha) + stats.norm.ppf(power)
    return float(optimize.brentq(short, fixed * 0.9, fixed * 1.5, xtol=1e-8))


def maximum_layouts(
    effect: float, sd: float, fractions: Fractions, alpha: float, power: float
) -> int:
    """The layouts a sequential plan's maximum needs so that its one-sided test at level alpha,
    looked at these fractions (each look at round(fraction n) layouts), finds a true
    difference ``effect`` with per-layout sd ``sd`` with probability ``power``. From the
    normal approximation's (drift sd / effect)^2 up, the first n whose power reaches it with
    each look's boundary moved to Student's t at that look's df (a t statistic crossing c_k
    is one crossing the t quantile of the same tail) and the t's spread about its centre m,
    sqrt(1 + m^2 / (2 df)), folded into the boundary: the known-variance figure alone leaves
    a t-based reading about 1 point short of its power (docs/design/sequential-plans.md)."""
    if effect == 0 or sd <= 0:
        raise ValueError(f"a maximum needs a non-zero effect and a positive sd, got {effect}, {sd}")
    t = check_fractions(fractions)
    c = boundaries(t, alpha)
    n = int(np.ceil((drift_for_power(t, alpha, power) * sd / abs(effect)) ** 2 - 1e-9))
    while True:
        looks = np.maximum(np.round(t * n), 2)
        bounds, df = stats.t.isf(stats.norm.sf(c), looks - 1), looks - 1
        drift = abs(effect) * np.sqrt(n) / sd
        mean = drift * np.sqrt(looks / n)  # the t's centre; its spread sqrt(1 + mean^2 / 2 df)
        bounds = mean + (bounds - mean) / np.sqrt(1 + mean**2 / (2 * df))
        if crossing_probability(bounds, looks / n, drift).sum() >= power:
            return n
        n += 1
