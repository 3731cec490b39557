"""Group-sequential boundaries for Student's t: the spread re-estimated at every look.

A cell's reading at a look is a paired t on the layouts read so far, turned into the normal z
with the same tail (``looks.z_of``). Each such z is exactly N(0, 1) when there is no effect,
but the looks' z are not jointly the Brownian motion :mod:`boundaries` assumes: every look
divides by its own estimate of the spread. Normal boundaries read that way (the "significance level
approach" of Jennison & Turnbull 2000, ch. 11) spend a little more than alpha:
one-sided 0.025 becomes 0.0251 at five looks of 200 layouts, 0.0252 at ten, 0.026 at ten of 40.

:func:`t_boundaries` finds, for a plan's looks (layout counts n_1 < ... < n_K), the z-scale
bounds b_k at which the t process's chance of crossing first at look k is exactly the
Lan-DeMets O'Brien-Fleming spending between looks k - 1 and k. With no effect the t's joint
law depends on nothing but the n_k (not on the mean's scale or the spread), so the bounds are
the plan's, computed once. They are found look by look as :func:`boundaries.boundaries` finds
its own, the crossing chance split into an exact and a simulated part:

    P(t crosses first at k) = P(Z crosses first at k) + E[1(t first at k) - 1(Z first at k)],

Z_k the known-spread z of the same simulated layouts. The first term is the recursion's
(exact), the second a Monte Carlo mean over ``replicates`` seeded null paths drawn from their
sufficient statistics (each group of layouts: a normal mean and a chi-square sum of squares).
Both indicators are taken at the same bounds on the same paths and mostly agree, so the
second term is small and its noise smaller than a plain simulation's; with many layouts a
look it vanishes and the bounds are the normal ones. The first look's bound is exact (the t
at look 1 maps to an exact N(0, 1)). Paths are drawn group by group from one seeded
generator, so a look's bound does not move when later looks are added.
docs/design/sequential-plans.md#boundaries-for-the-t
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from scipy import optimize, stats

from d3dwa_bullet.evaluation.plans.boundaries import (
    boundaries,
    carry_density,
    check_fractions,
    grid_to,
    spending,
    trapezoid_weights,
)
from d3dwa_bullet.evaluation.plans.looks import z_of

REPLICATES = 2_000_000
"""Null paths of the Monte Carlo term: its noise on a one-sided level is about 1e-4
at 2.5 % (docs/design/sequential-plans.md#boundaries-for-the-t); a few seconds for ten looks."""
SEED = 77_011
"""The paths' seed: fixed, so a plan's bounds are the same on every run and resume."""
CHUNK = 500_000
"""Paths drawn at a time (memory: a chunk's (CHUNK, K) arrays)."""

Tails = tuple[np.ndarray, np.ndarray, np.ndarray]
"""A process's values at or above a floor, as (path index, look index, z) arrays (E,)."""


def null_tails(n: tuple[int, ...], replicates: int, seed: int, floor: float) -> tuple[Tails, Tails]:
    """The tails at or above ``floor`` of (z of the t, known-spread z) over ``replicates`` paths
    of paired differences N(0, 1) read at layout counts n (K,): u_k = z_of(t_k, n_k - 1),
    Z_k = sum / sqrt(n_k). Drawn per (chunk, group) from ``[seed, chunk, group]``, so a look's
    draws do not depend on the looks after it."""
    looks = np.asarray(n, dtype=float)
    sizes = np.diff(np.concatenate([[0], n]))
    t_floor = stats.t.isf(stats.norm.sf(floor), looks - 1)
    out: list[list[np.ndarray]] = [[], [], [], [], [], []]
    for c, first in enumerate(range(0, replicates, CHUNK)):
        r = min(CHUNK, replicates - first)
        s, q = np.empty((r, len(n))), np.empty((r, len(n)))
        for k, m in enumerate(sizes):
            rng = np.random.default_rng([seed, c, k])
            mean = rng.normal(0.0, 1.0 / np.sqrt(m), size=r)
            s[:, k] = m * mean
            q[:, k] = (rng.chisquare(m - 1, size=r) if m > 1 else 0.0) + m * mean**2
        s, q = np.cumsum(s, axis=1), np.cumsum(q, axis=1)
        with np.errstate(
            divide="ignore", invalid="ignore"
        ):  # no spread: t is inf (or nan, not kept)
            t = (s / looks) / np.sqrt(np.maximum(q - s**2 / looks, 0.0) / (looks - 1) / looks)
        z = s / np.sqrt(looks)
        for j, (hit, value) in enumerate(((t >= t_floor, None), (z >= floor, z))):
            rows, cols = np.nonzero(hit)
            v = z_of(t[rows, cols], looks[cols] - 1) if value is None else value[rows, cols]
            out[3 * j].append(rows + first)
            out[3 * j + 1].append(cols)
            out[3 * j + 2].append(v)
    joined = [np.concatenate(x) for x in out]
    return (joined[0], joined[1], joined[2]), (joined[3], joined[4], joined[5])


def t_boundaries(
    looks: Sequence[int] | np.ndarray, maximum: int, alpha: float,
    replicates: int = REPLICATES, seed: int = SEED,
) -> np.ndarray:  # fmt: skip
    """(K,) z-scale upper bounds of a one-sided level-alpha test read by paired t at layout
    counts ``looks`` (increasing, the first >= 2) of ``maximum`` layouts, Lan-DeMets
    O'Brien-Fleming spending at fractions looks / maximum: a t at look k reads when
    ``looks.z_of(t, n_k - 1)`` is at or above b_k. Cached per arguments."""
    return np.array(
        _solve(_sizes(looks), int(maximum), (float(alpha),), int(replicates), int(seed))[0]
    )


def rule_boundaries(
    looks: Sequence[int] | np.ndarray, maximum: int, alpha: float,
    replicates: int = REPLICATES, seed: int = SEED,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The plan's two bound sets for the t, (the difference's at alpha / 2, TOST's at alpha),
    each (K,) as :func:`t_boundaries` gives it, from one set of null paths (half the time)."""
    got = _solve(_sizes(looks), int(maximum), (alpha / 2, float(alpha)), int(replicates), int(seed))
    return np.array(got[0]), np.array(got[1])


def _sizes(looks: Sequence[int] | np.ndarray) -> tuple[int, ...]:
    n = tuple(int(x) for x in np.asarray(looks).ravel())
    if len(n) == 0 or n[0] < 2:
        raise ValueError(f"a t's looks need 2 or more layouts each, got {list(n)}")
    return n


class _Alive:
    """One process's tail entries, and which paths have crossed an earlier look's bound."""

    def __init__(self, tail: Tails, replicates: int) -> None:
        self.path, self.look, self.value = tail
        self.dead = np.zeros(replicates, dtype=bool)

    def at(self, k: int) -> np.ndarray:
        """The sorted values at look k of the paths not yet crossed."""
        pick = (self.look == k) & ~self.dead[self.path]
        return np.sort(self.value[pick])

    def cross(self, k: int, bound: float) -> None:
        pick = (self.look == k) & (self.value >= bound)
        self.dead[self.path[pick]] = True


@lru_cache(maxsize=64)
def _solve(
    n: tuple[int, ...], maximum: int, alphas: tuple[float, ...], replicates: int, seed: int
) -> tuple[tuple[float, ...], ...]:
    t = check_fractions(np.asarray(n) / maximum)
    floor = min(float(np.min(boundaries(t, a))) for a in alphas) - 1.0  # the t's are within 1
    tails = null_tails(n, replicates, seed, floor)
    return tuple(_bounds(t, a, tails, replicates, floor) for a in alphas)


def _bounds(
    t: np.ndarray, alpha: float, tails: tuple[Tails, Tails], replicates: int, floor: float
) -> tuple[float, ...]:
    """The bounds at level alpha for fractions t from the null paths' tails (the module's
    docstring)."""
    spent = np.diff(np.concatenate([[0.0], spending(t, alpha)]))
    u, zk_ = _Alive(tails[0], replicates), _Alive(tails[1], replicates)
    b = np.empty(t.size)
    b[0] = stats.norm.isf(spent[0])
    z = grid_to(b[0])
    density = stats.norm.pdf(z) * trapezoid_weights(z)
    for k in range(t.size):
        if k > 0:
            sd = np.sqrt((t[k] - t[k - 1]) / t[k])
            mean = z * np.sqrt(t[k - 1] / t[k])
            uk, zk = u.at(k), zk_.at(k)

            def excess(
                bk: float, mean: np.ndarray = mean, sd: float = sd, f: np.ndarray = density,
                uk: np.ndarray = uk, zk: np.ndarray = zk, k: int = k,
            ) -> float:  # fmt: skip
                exact = float(stats.norm.sf((bk - mean) / sd) @ f)
                mc = (uk.size - np.searchsorted(uk, bk)) - (zk.size - np.searchsorted(zk, bk))
                return exact + mc / replicates - spent[k]

            b[k] = optimize.brentq(excess, floor, 40.0, xtol=1e-10)
            grid = grid_to(b[k])
            density = carry_density(density, z, t[k - 1], t[k], grid, 0.0) * trapezoid_weights(grid)
            z = grid
        u.cross(k, b[k])
        zk_.cross(k, b[k])
    return tuple(float(x) for x in b)
