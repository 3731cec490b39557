"""The history observation (docs/design/observation.md#history-observation): pure, shared by the simulator's
episode loop, the bag replay and ``drive``.

The ``history`` kind is the paper's 12-d state of this control step, the same 12 entries of the
``HISTORY_STEPS - 1`` control steps before it (most recent first), and the previous action:

  d_goal ... sector_7            this step, as the ``paper`` kind
  d_goal@-1 ... sector_7@-9      the step before, ..., nine steps before (0.1 s apart at 10 Hz)
  prev_wp/wc/ws, prev_tau        the controller's last choice, as the ``progress`` kind

Before an episode has ``HISTORY_STEPS`` observations, the missing past repeats the oldest one
it has (at the first step, the current one): no entry is a made-up number outside its range.
Ten steps are one decision period of the shipped policies (1 s): a held decision sees every
control step since the last one. It is the window on which a small classifier tells ``harsh``
from ``none`` nine times in ten, where one observation tells it three times in four
(docs/noise.md#regime): an RMA-style short memory (Kumar et al. 2021; Peng et al. 2018) that
lets the policy infer the noise regime it acts in.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from d3dwa_bullet.params import ProgressObservationParams
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.planning.progress import PREVIOUS_ACTION_LAYOUT, previous_action_entries
from d3dwa_bullet.planning.recovery import Pose

HISTORY_STEPS = 10
"""Control steps the history kind sees, this one included (1 s at 10 Hz)."""
HISTORY_LAYOUT = (
    OBSERVATION_LAYOUT
    + tuple(f"{name}@-{lag}" for lag in range(1, HISTORY_STEPS) for name in OBSERVATION_LAYOUT)
    + PREVIOUS_ACTION_LAYOUT
)
"""Entry names of the ``history`` kind: 12 x HISTORY_STEPS + 4 = 124."""


class HistoryObserver:
    """Turns each paper observation into the ``history`` one, step by step: one instance per
    episode or replayed bag. ``extend`` at every observation, ``chose`` with every action the
    controller picks (not what a recovery layer drove instead). The observer interface of
    ``planning.observation_kinds``."""

    def __init__(self, params: ProgressObservationParams | None = None) -> None:
        self.params = params or ProgressObservationParams()
        self.past: deque[np.ndarray] = deque(maxlen=HISTORY_STEPS - 1)
        """The paper observations of the steps before this one, most recent first."""
        self.previous: PlannerAction | None = None

    def extend(self, obs: np.ndarray, t_ns: int, pose: Pose | np.ndarray) -> np.ndarray:
        """obs (12,) of this control step -> (124,) float64. t_ns and pose are not read (the
        observer interface passes them)."""
        now = np.asarray(obs, dtype=np.float64)
        if now.shape != (len(OBSERVATION_LAYOUT),):
            raise ValueError(
                f"history observation: expected the ({len(OBSERVATION_LAYOUT)},) paper "
                f"observation, got shape {now.shape}"
            )
        past = list(self.past)
        oldest = past[-1] if past else now
        past += [oldest] * (HISTORY_STEPS - 1 - len(past))
        out = np.concatenate([now, *past, previous_action_entries(self.previous, self.params)])
        self.past.appendleft(now.copy())
        return out

    def chose(self, action: PlannerAction) -> None:
        self.previous = action
