"""A cell at a look: its estimate as plain numbers, read against the look's boundaries.

At each look a cell's estimate is three numbers (:class:`Estimate`): the mean difference
A - B, its standard error and its degrees of freedom, from one callable per question
(:data:`ESTIMATORS`): ``policies`` is today's reading (paired by layout, each side averaged
over its seeds there: ``paired.paired_scores(..., by_seed=False)``); ``recipe`` is the recipe-level
estimate (the training seed a random effect: :func:`recipe.recipe_estimate`).

The statistic t = difference / se is turned into the z with the same one-sided p
(Phi^-1 of Student's t cdf at df), so a boundary on the normal scale holds for a t with few
degrees of freedom. The reading at a look (:func:`decisions`, vectorised):

- ``A better`` / ``B better``: z of A > B (of B > A) at or above the difference boundary
  (Lan-DeMets O'Brien-Fleming at alpha / 2 each way);
- ``equivalent``: otherwise, when both of TOST's one-sided z, (difference + margin) / se and
  (margin - difference) / se, are at or above the TOST boundary (the same spending at alpha);
- open otherwise; a cell open after its last look is ``inconclusive``.

A difference crossing with an equivalence reads as the difference, as the fixed-N rule does
(``readings.read_differences``). docs/design/sequential-plans.md.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from d3dwa_bullet.evaluation import recipe
from d3dwa_bullet.evaluation.paired import MIN_LAYOUTS, Row, mean_sd, paired_scores
from d3dwa_bullet.evaluation.recipe import Estimate

OPEN, A_BETTER, B_BETTER, EQUIVALENT, INCONCLUSIVE = 0, 1, 2, 3, 4
"""A cell's state after a look, as :func:`decisions` codes it."""
DECISIONS = {OPEN: "open", A_BETTER: "A better", B_BETTER: "B better", EQUIVALENT: "equivalent",
             INCONCLUSIVE: "inconclusive"}  # fmt: skip


Estimator = Callable[[Sequence[Row], str, str, str], Estimate]
"""(the cell's rows over the layouts read, A, B, metric) -> its :class:`Estimate`."""


def differences_estimate(d: Sequence[float] | np.ndarray) -> Estimate:
    """The estimate of per-layout differences d (n >= 2,): their mean, sd / sqrt(n), n - 1
    (``paired.mean_sd``: a spread below rounding is 0). ValueError for fewer than 2 or NaN."""
    x = np.asarray(d, dtype=float)
    if x.size < MIN_LAYOUTS or not np.isfinite(x).all():
        raise ValueError(
            f"an estimate needs {MIN_LAYOUTS} or more finite differences, got {x.size}"
        )
    mean, sd = mean_sd(x)
    return Estimate(mean, sd / np.sqrt(x.size), float(x.size - 1))


def policies_estimate(rows: Sequence[Row], a: str, b: str, metric: str) -> Estimate:
    """These policies: paired by layout, each side averaged over its training and evaluation
    seeds there (the reading of ``readings.reading_of``)."""
    scores = paired_scores(rows, a, b, by_seed=False, metric=metric)
    return differences_estimate([sa - sb for sa, sb in scores.values()])


def recipe_estimate(rows: Sequence[Row], a: str, b: str, metric: str) -> Estimate:
    """The recipe (the training seed a random effect): :func:`recipe.recipe_estimate` on the
    two sides' (seed x layout) tables over the layouts every seed ran. ResultsError naming a
    learned side with one training seed."""
    for method in (a, b):
        recipe.check_recipe_side(rows, method)
    ta, tb, layouts = recipe.seed_layout_tables(rows, a, b, metric)
    if len(layouts) < MIN_LAYOUTS:
        raise ValueError(
            f"an estimate needs {MIN_LAYOUTS} or more shared layouts, got {len(layouts)}"
        )
    return recipe.recipe_estimate(ta, tb)


ESTIMATORS: dict[str, Estimator] = {"policies": policies_estimate, "recipe": recipe_estimate}
"""One estimator per question of ``recipe.QUESTIONS``: the one place a new one plugs in."""


def z_of(t: ArrayLike, df: ArrayLike) -> np.ndarray:
    """The standard normal z with the same upper tail as Student's t at df (elementwise;
    +-inf stays +-inf)."""
    t, df = np.broadcast_arrays(np.asarray(t, dtype=float), np.asarray(df, dtype=float))
    return np.asarray(stats.norm.isf(stats.t.sf(t, df)))


def _ratio(x: np.ndarray, se: np.ndarray) -> np.ndarray:
    """x / se, the limit where se is 0: +-inf by x's sign, -inf for 0 / 0 (no evidence)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = x / se
    return np.where(se > 0, r, np.where(x > 0, np.inf, -np.inf))


def equivalence_z(difference: ArrayLike, se: ArrayLike, df: ArrayLike, margin: float) -> np.ndarray:
    """The smaller of TOST's two one-sided z, (difference + margin) / se and (margin -
    difference) / se, each through the t's tail at df (elementwise): equivalence reads when it
    is at or above the TOST boundary."""
    d, s = np.asarray(difference, dtype=float), np.asarray(se, dtype=float)
    return np.minimum(z_of(_ratio(d + margin, s), df), z_of(_ratio(margin - d, s), df))


def decisions(
    difference: ArrayLike, se: ArrayLike, df: ArrayLike, margin: float,
    bound_difference: ArrayLike, bound_tost: ArrayLike,
) -> np.ndarray:  # fmt: skip
    """The code (OPEN, A_BETTER, B_BETTER, EQUIVALENT) of each estimate against its look's
    boundaries; every argument broadcasts to one shape (e.g. (replicates, looks))."""
    d, s = np.asarray(difference, dtype=float), np.asarray(se, dtype=float)
    z_a, z_b = z_of(_ratio(d, s), df), z_of(_ratio(-d, s), df)
    code = np.full(np.broadcast(d, s, bound_difference).shape, OPEN)
    code = np.where(equivalence_z(d, s, df, margin) >= bound_tost, EQUIVALENT, code)
    code = np.where(z_b >= bound_difference, B_BETTER, code)
    return np.where(z_a >= bound_difference, A_BETTER, code)


def first_reading(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """codes (..., K) of the looks in order -> (the reading, the look index it came at): the
    first code not OPEN, else INCONCLUSIVE at the last look."""
    c = np.asarray(codes)
    read = c != OPEN
    look = np.where(read.any(axis=-1), read.argmax(axis=-1), c.shape[-1] - 1)
    got = np.take_along_axis(c, look[..., None], axis=-1)[..., 0]
    return np.where(got == OPEN, INCONCLUSIVE, got), look


def prefix_estimates(d: np.ndarray, looks: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """d (..., n) per-layout differences in their order -> (difference, se, df), each
    (..., K): the estimate of the first looks[k] layouts (a vectorised
    :func:`differences_estimate`, the same arithmetic)."""
    x = np.asarray(d, dtype=float)
    n = np.asarray(looks, dtype=int)
    s1 = np.cumsum(x, axis=-1)[..., n - 1]
    mean = s1 / n
    centred = np.cumsum((x - x[..., :1]) ** 2, axis=-1)[..., n - 1]  # shifted for stability
    shift = mean - x[..., :1]
    var = np.maximum(centred - n * shift**2, 0.0) / (n - 1)
    sd = np.sqrt(var)
    scale = np.maximum(1.0, np.maximum.accumulate(np.abs(x), axis=-1)[..., n - 1])
    sd = np.where(sd <= 1e-9 * scale, 0.0, sd)
    return mean, sd / np.sqrt(n), np.broadcast_to((n - 1).astype(float), mean.shape)
