"""The discrete action space: one index -> DWA weights (wp, wc, ws) and horizon tau.

An action is a tuple of the Cartesian product W^3 x T (docs/design/methods.md#actions, paper Eq. action).
Only weight *ratios* matter to the planner (it maximises a weighted sum of criteria that
are each normalised to [0, 1]), so the uniform triples (c, c, c) all describe the same
planner; only the one with the smallest candidate is kept. With W = {1, 2, 3} this removes
every duplicate ratio and leaves (|W|^3 - |W| + 1) |T| = 25 * 4 = 100 actions. For other
candidate sets further ratio duplicates may exist (e.g. (1, 1, 2) and (2, 2, 4) when
W = {1, 2, 4}); they are kept, exactly as the paper's count implies.

Order (horizon-major): ``index = horizon_slot * n_triples + triple_slot``. Within a horizon
block the weight triples run in lexicographic order of their candidate positions, with
wp slowest and ws fastest, uniform triples other than the smallest skipped::

    0: (1, 1, 1)   1: (1, 1, 2)   2: (1, 1, 3)   3: (1, 2, 1) ... 24: (3, 3, 2)

so ``index % n_triples`` is the weight triple and ``index // n_triples`` the horizon, and
the weights-only set (T = {4 s}) uses the same triple numbering as every block of the full
set.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from d3dwa_bullet.errors import ConfigError


class PlannerAction(NamedTuple):
    """DWA evaluation weights and prediction horizon chosen for one control step."""

    wp: float
    """Progress weight."""
    wc: float
    """Clearance weight."""
    ws: float
    """Speed weight."""
    tau: float
    """Prediction horizon, s."""


#: Horizon used by the fixed-weight baselines and every weights-only method, s.
FIXED_HORIZON = 4.0


def _candidates(values: Iterable[float], what: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"ActionSet.{what}: candidates must be numbers, got {values!r}") from err
    if not out:
        raise ConfigError(f"ActionSet.{what}: the candidate set is empty")
    for v in out:
        if not np.isfinite(v) or v <= 0:
            raise ConfigError(f"ActionSet.{what}: candidate {v!r} must be a finite number > 0")
    seen: set[float] = set()
    for v in out:
        if v in seen:
            raise ConfigError(f"ActionSet.{what}: duplicate candidate {v!r} in {out!r}")
        seen.add(v)
    if list(out) != sorted(out):
        raise ConfigError(f"ActionSet.{what}: candidates must be increasing, got {out!r}")
    return out


@dataclass(frozen=True)
class ActionSet:
    """A discrete action table built from weight and horizon candidates (see module docstring).

    Candidates must be finite, > 0, distinct and increasing; otherwise ConfigError.
    """

    weights: tuple[float, ...] = (1.0, 2.0, 3.0)
    """Weight candidates W (unitless)."""
    horizons: tuple[float, ...] = (2.0, 3.0, 4.0, 5.0)
    """Prediction-horizon candidates T, s."""
    _table: tuple[PlannerAction, ...] = field(init=False, repr=False, compare=False)
    _index: dict[PlannerAction, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        weights = _candidates(self.weights, "weights")
        horizons = _candidates(self.horizons, "horizons")
        object.__setattr__(self, "weights", weights)
        object.__setattr__(self, "horizons", horizons)
        triples = [
            t
            for t in itertools.product(weights, repeat=3)
            if not (t[0] == t[1] == t[2]) or t[0] == weights[0]
        ]
        table = tuple(PlannerAction(t[0], t[1], t[2], tau) for tau in horizons for t in triples)
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_index", {a: i for i, a in enumerate(table)})

    @property
    def size(self) -> int:
        """Number of actions |A| = (|W|^3 - |W| + 1) |T|."""
        return len(self._table)

    @property
    def n_triples(self) -> int:
        """Number of distinct weight triples (the length of one horizon block)."""
        return len(self._table) // len(self.horizons)

    def __len__(self) -> int:
        return len(self._table)

    @property
    def actions(self) -> tuple[PlannerAction, ...]:
        """Every action, in index order."""
        return self._table

    def decode(self, index: int) -> PlannerAction:
        """The planner tuple of action ``index`` (0 <= index < size), else ConfigError."""
        i = int(index)
        if i != index or not 0 <= i < len(self._table):
            raise ConfigError(f"action index {index!r} out of range [0, {len(self._table)})")
        return self._table[i]

    def encode(self, action: PlannerAction | tuple[float, float, float, float]) -> int:
        """The index of a (wp, wc, ws, tau) tuple; ConfigError if it is not in the table.

        A uniform triple (c, c, c) with c in W encodes to the retained equivalent
        (W[0], W[0], W[0]) with the same horizon.
        """
        key = PlannerAction(*(float(v) for v in action))
        if key.wp == key.wc == key.ws and key.wp in self.weights:
            w0 = self.weights[0]
            key = PlannerAction(w0, w0, w0, key.tau)
        try:
            return self._index[key]
        except KeyError:
            raise ConfigError(
                f"action {tuple(action)!r} is not in the action set "
                f"(weights={self.weights}, horizons={self.horizons})"
            ) from None

    def table(self) -> np.ndarray:
        """The whole table as an array: (size, 4) float64, columns wp, wc, ws, tau (s)."""
        return np.array(self._table, dtype=np.float64)

    def weights_only(self, horizon: float = FIXED_HORIZON) -> ActionSet:
        """The same weight candidates with the horizon fixed to ``horizon`` s."""
        return ActionSet(self.weights, (horizon,))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (checkpoint metadata); ``from_dict`` inverts it."""
        return {"weights": list(self.weights), "horizons": list(self.horizons), "size": self.size}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ActionSet:
        """Rebuild from ``to_dict`` output; ConfigError on missing fields or a size mismatch."""
        try:
            out = cls(tuple(data["weights"]), tuple(data["horizons"]))
        except (KeyError, TypeError) as err:
            raise ConfigError(
                f"action set description {dict(data)!r} lacks weights/horizons"
            ) from err
        if "size" in data and data["size"] != out.size:
            raise ConfigError(
                f"action set description says size={data['size']!r} but its candidates give {out.size}"
            )
        return out


#: The full D3DWA action space: W = {1, 2, 3}, T = {2, 3, 4, 5} s, 100 actions.
ACTIONS_FULL = ActionSet()
#: The weights-only action space (d3dwa-weights, dqdwa): T = {4 s}, 25 actions.
ACTIONS_WEIGHTS_ONLY = ACTIONS_FULL.weights_only()
