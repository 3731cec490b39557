"""Value calibration: does a learner's Q track the return its own greedy policy earns?

For every (s_t, a_t) a greedy episode visited, the learner predicts Q(s_t, a_t), and the
episode then earns the discounted return G_t = sum_k gamma^k r_{t+k} from there to its end.
A learner whose values track its returns has mean Q close to mean G over those pairs; one
whose bootstrapped targets ran away (the overestimation of a max over many near-identical
actions) has mean Q many times the most any episode can earn (docs/design/agent.md#value-calibration).

The rule a pilot or a shipped seed is judged by (issue 29): the ratio mean Q / mean G lies
in [0.67, 1.5]; where the mean return is under 0.1 in magnitude a ratio means little, so
there |mean Q - mean G| must be at most 0.05 instead. A truncated episode's return stops at
the time limit (nothing is bootstrapped beyond it): its last values are honestly above what
it earned, which the band allows for. Pure numpy: no torch, no pybullet.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

RATIO_BAND = (0.67, 1.5)
"""Mean Q over mean discounted return inside this band: calibrated."""
SMALL_RETURN = 0.1
"""Below this mean |return|, the absolute gap is judged instead of the ratio."""
ABS_TOLERANCE = 0.05
"""The largest |mean Q - mean return| allowed where the mean return is small."""


def discounted_returns(rewards: Sequence[float] | np.ndarray, gamma: float) -> np.ndarray:
    """G_t = r_t + gamma G_{t+1}, G_T = 0: the return each step of one episode went on to earn."""
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"discounted_returns: gamma must be in [0, 1], got {gamma!r}")
    r = np.asarray(rewards, dtype=np.float64)
    out = np.empty_like(r)
    acc = 0.0
    for t in range(len(r) - 1, -1, -1):
        acc = r[t] + gamma * acc
        out[t] = acc
    return out


@dataclass(frozen=True)
class ValueCalibration:
    """Mean Q of the visited (s, a) pairs against the mean discounted return they earned."""

    mean_q: float
    mean_return: float
    pairs: int
    episodes: int

    @property
    def ratio(self) -> float | None:
        """mean Q / mean return (None when the mean return is exactly 0)."""
        return self.mean_q / self.mean_return if self.mean_return != 0 else None

    @property
    def gap(self) -> float:
        """mean Q - mean return."""
        return self.mean_q - self.mean_return

    @property
    def judged_by(self) -> str:
        """Which figure ("ratio" or "gap") the rule reads for this mean return."""
        return "gap" if abs(self.mean_return) < SMALL_RETURN else "ratio"

    @property
    def calibrated(self) -> bool:
        """The rule of the module docstring."""
        if not (math.isfinite(self.mean_q) and math.isfinite(self.mean_return)):
            return False
        if self.judged_by == "gap":
            return abs(self.gap) <= ABS_TOLERANCE
        lo, hi = RATIO_BAND
        return lo <= (self.ratio or 0.0) <= hi

    def describe(self) -> str:
        """One line: mean Q, mean return, the figure judged and the verdict."""
        figure = f"ratio {self.ratio:.2f}" if self.judged_by == "ratio" else f"gap {self.gap:+.3f}"
        verdict = "tracks its returns" if self.calibrated else "does NOT track its returns"
        return (
            f"mean Q {self.mean_q:.3f} vs discounted return {self.mean_return:.3f} "
            f"({figure}, {self.pairs} pairs in {self.episodes} episodes): {verdict}"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "mean_q": self.mean_q,
            "mean_return": self.mean_return,
            "ratio": self.ratio,
            "gap": self.gap,
            "pairs": self.pairs,
            "episodes": self.episodes,
            "calibrated": self.calibrated,
        }


def calibrate(
    q_taken: Sequence[Sequence[float] | np.ndarray],
    rewards: Sequence[Sequence[float] | np.ndarray],
    gamma: float,
) -> ValueCalibration:
    """Pool every step of every episode: q_taken[e][t] = Q(s_t, a_t), rewards[e][t] = r_t."""
    if len(q_taken) != len(rewards) or not q_taken:
        raise ValueError(
            f"calibrate: need one Q series per reward series, got {len(q_taken)} and {len(rewards)}"
        )
    qs, gs = [], []
    for q, r in zip(q_taken, rewards, strict=True):
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (len(r),):
            raise ValueError(f"calibrate: {len(q)} Q values for an episode of {len(r)} steps")
        qs.append(q)
        gs.append(discounted_returns(r, gamma))
    q_all, g_all = np.concatenate(qs), np.concatenate(gs)
    if not len(q_all):
        raise ValueError("calibrate: the episodes have no steps")
    return ValueCalibration(float(q_all.mean()), float(g_all.mean()), len(q_all), len(qs))


def calibrate_by_outcome(
    q_taken: Sequence[Sequence[float] | np.ndarray],
    rewards: Sequence[Sequence[float] | np.ndarray],
    outcomes: Sequence[str],
    gamma: float,
) -> dict[str, ValueCalibration]:
    """Where do the values miss? ``calibrate`` over the episodes that reached the goal
    ("goal") and over the rest ("not goal"), each key present only when it has episodes.

    A learner can track the returns of the paths it finishes and still value a stall (an
    episode that ends at the time limit) as if the goal were near; the pooled figure hides
    which (docs/design/agent.md#value-calibration).
    """
    if len(outcomes) != len(q_taken):
        raise ValueError(
            f"calibrate_by_outcome: {len(outcomes)} outcomes for {len(q_taken)} episodes"
        )
    groups: dict[str, list[int]] = {}
    for i, outcome in enumerate(outcomes):
        groups.setdefault("goal" if outcome == "goal" else "not goal", []).append(i)
    return {
        name: calibrate([q_taken[i] for i in idx], [rewards[i] for i in idx], gamma)
        for name, idx in sorted(groups.items())
    }
