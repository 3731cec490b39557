"""What a policy reads, by kind (docs/design/observation.md#observation): the one home of the kinds, their
entry names and the per-episode state each needs. Pure.

  paper     the 12-d state of ``planning.observation`` (SPEC 6)
  progress  that state and five progress entries (``planning.progress``, 17-d)
  history   that state over the last 10 control steps and the previous action
            (``planning.history``, 124-d)

Every kind is built the same way wherever an episode runs (the simulator's ``Episode``, the bag
replay, ``drive``): the paper state, then the kind's observer, if it has one, ``extend``\\ s it
at each control step and is told what the controller ``chose``.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import OBSERVATION_KINDS
from d3dwa_bullet.planning.history import HISTORY_LAYOUT, HistoryObserver
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.planning.progress import PROGRESS_LAYOUT, ProgressObserver
from d3dwa_bullet.planning.recovery import Pose

LAYOUTS: dict[str, tuple[str, ...]] = {
    "paper": OBSERVATION_LAYOUT,
    "progress": OBSERVATION_LAYOUT + PROGRESS_LAYOUT,
    "history": HISTORY_LAYOUT,
}
"""Entry names of each observation kind, in order."""
SIGNED_ENTRIES = ("theta_goal", "v", "w")
"""Entries in [-1, 1] (at any lag); every other entry of every kind is in [0, 1]."""


class Observer(Protocol):
    """The per-episode state of an observation kind beyond the paper's."""

    def extend(self, obs: np.ndarray, t_ns: int, pose: Pose | np.ndarray) -> np.ndarray: ...

    def chose(self, action: PlannerAction) -> None: ...


def check_observation_kind(kind: object, where: str = "observation") -> str:
    """``kind`` if it is one of OBSERVATION_KINDS, else ConfigError naming ``where`` and it."""
    if kind not in OBSERVATION_KINDS:
        raise ConfigError(
            f"{where}: unknown observation kind {kind!r}; choose one of {', '.join(OBSERVATION_KINDS)}"
        )
    return str(kind)


def observation_layout(kind: str) -> tuple[str, ...]:
    """Entry names of an observation kind (ConfigError for an unknown kind)."""
    return LAYOUTS[check_observation_kind(kind)]


def observation_low(layout: tuple[str, ...]) -> np.ndarray:
    """Lower bound of each entry of a layout: -1 for the signed ones, else 0 (float32)."""
    return np.array(
        [-1.0 if name.partition("@")[0] in SIGNED_ENTRIES else 0.0 for name in layout],
        dtype=np.float32,
    )


def kind_of_layout(layout: tuple[str, ...] | list[str]) -> str | None:
    """The kind whose layout this is (None: none of them, e.g. a custom number of sectors)."""
    return next((k for k, names in LAYOUTS.items() if tuple(layout) == names), None)


def make_observer(kind: str) -> Observer | None:
    """The per-episode state an observation kind needs (None for ``paper``: none)."""
    kind = check_observation_kind(kind)
    if kind == "progress":
        return ProgressObserver()
    if kind == "history":
        return HistoryObserver()
    return None
