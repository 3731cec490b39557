"""A plan's multiplicity control: each cell's level at each look, and the reading at that level.

A plan reads m cells, a cell being (pair, profile, family); ``multiplicity`` names how the
plan's alpha is shared among them (docs/design/sequential-plans.md#multiplicity):

- ``none``: every cell at alpha (the rule before multiplicity was named);
- ``bonferroni``: every cell at alpha / m, at every look;
- ``holm``: Holm's procedure carried into the group-sequential setting by alpha recycling
  (Maurer & Bretz 2013, the graph with Holm's equal weights): every cell starts at alpha / m; a
  cell that has rejected both of its nulls passes its level in equal shares to the others, so
  with p such cells every other cell is at alpha / (m - p). Within a look the cells of the look
  are re-read at the raised level until no further cell passes (a raised level's boundaries are
  lower at every look, so a reading only ever moves from open to read, or from equivalent to a
  difference read with its equivalence).

A cell's level covers its reading whole, as the fixed rule's alpha does: the difference at
level / 2 each way and TOST at the level. A cell has two nulls, no difference (mean 0) and not
equivalent (|mean| >= margin), and at most one is true, so one level bounds its chance of a
false read. The level passes only from a cell that has read a difference and equivalence at
once (0 < |mean| < margin, shown both ways): a cell that reads only one of them leaves the
other null unrejected and possibly true, and its level stays with it, as the closed test
behind Holm's procedure requires. Passing on any first read, as a plain step-down would, lets
a tie that reads equivalent hand its level on while its own chance of a false difference is
spent: simulated, four such ties read a false difference 9.7 % of the time at alpha 5 %
(``tools/experiments/multiplicity_check.py --naive``). Pure: numpy; boundaries from
``student.rule_boundaries``, cached per level.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.evaluation.plans.looks import A_BETTER, B_BETTER, OPEN, decisions, equivalence_z
from d3dwa_bullet.evaluation.plans.student import REPLICATES, rule_boundaries

MULTIPLICITY = ("none", "bonferroni", "holm")
"""The multiplicity controls a plan may name; ``none`` when it names none."""


@dataclass(frozen=True)
class Levels:
    """A plan's multiplicity control: its rule (one of :data:`MULTIPLICITY`), alpha and m."""

    rule: str
    alpha: float
    cells: int

    def __post_init__(self) -> None:
        if self.rule not in MULTIPLICITY or self.cells < 1 or not 0 < self.alpha < 0.5:
            raise ValueError(
                f"levels need a rule of {MULTIPLICITY}, m >= 1 and alpha in (0, 0.5), got {self}"
            )

    def level(self, passed: np.ndarray | int) -> np.ndarray:
        """The level of a cell (array like ``passed``) once ``passed`` cells have passed theirs."""
        p = np.asarray(passed)
        if self.rule == "none":
            return np.full(p.shape, self.alpha)
        if self.rule == "bonferroni":
            return np.full(p.shape, self.alpha / self.cells)
        return self.alpha / (self.cells - np.minimum(p, self.cells - 1))


class LevelBounds:
    """The boundaries of one family's looks at any level (``student.rule_boundaries``, cached
    there per level): (the difference's at level / 2, TOST's at level), each (K,)."""

    def __init__(
        self, looks: Sequence[int] | np.ndarray, maximum: int, replicates: int = REPLICATES
    ) -> None:
        self.looks = tuple(int(n) for n in looks)
        self.maximum, self.replicates = int(maximum), int(replicates)

    def at(self, level: float) -> tuple[np.ndarray, np.ndarray]:
        return rule_boundaries(self.looks, self.maximum, float(level), self.replicates)

    def look(self, levels: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(difference bound, TOST bound) at look k (0-based) for each level of ``levels``
        (any shape), one boundary computation per distinct level."""
        bd, bt = np.empty(levels.shape), np.empty(levels.shape)
        for value in np.unique(levels):
            b = self.at(float(value))
            bd[levels == value], bt[levels == value] = b[0][k], b[1][k]
        return bd, bt


def read_look(
    difference: np.ndarray, se: np.ndarray, df: np.ndarray, margin: float, is_open: np.ndarray,
    passed: np.ndarray, levels: Levels, bounds: LevelBounds, k: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The cells open at look k read at their levels: difference, se, df and is_open (R, C) of
    R replicates (a plan run: R = 1) of C cells, passed (R,) the cells passed before this look.
    Returns (code (R, C): OPEN, A_BETTER, B_BETTER or EQUIVALENT, OPEN where not is_open;
    passed (R,) after the look; level (R, C): the level each cell's reading came at, the look's
    last for a cell left open). The open cells are re-read at the raised level until no further
    one passes; a raise only adds crossings, so a reading moves from open to read, or from
    equivalent to a difference (read with its equivalence: it passes)."""
    passed0 = np.asarray(passed, dtype=int)
    now, code = passed0.copy(), np.full(np.shape(is_open), OPEN)
    at = np.zeros(np.shape(is_open))
    while True:
        level = levels.level(now)
        bd, bt = bounds.look(level, k)
        got = np.where(
            is_open, decisions(difference, se, df, margin, bd[:, None], bt[:, None]), OPEN
        )
        changed = (got != code) | (got == OPEN)
        code, at = got, np.where(changed, level[:, None], at)
        both = np.isin(code, (A_BETTER, B_BETTER)) & (
            equivalence_z(difference, se, df, margin) >= bt[:, None]
        )
        after = passed0 + both.sum(axis=-1) if levels.rule == "holm" else passed0
        if np.array_equal(after, now):
            return code, now, at
        now = after
