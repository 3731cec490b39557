"""The progress-aware observation (docs/design/observation.md#progress-observation): pure, shared by the
simulator's episode loop and the bag replay.

The ``paper`` kind is the 12-d state of ``planning.observation``, unchanged. The ``progress``
kind appends five entries, all in [0, 1]:

  stalled     time since the *estimated* pose last made progress / window, clipped to 1
  prev_wp/wc/ws  the weights the controller chose at the previous step / weight_max
  prev_tau    the horizon it chose then / tau_max
(0 for every previous-action entry before the first choice: no action is all zeros.)

"Progress" has one home, the recovery layer's ``ProgressChecker`` (Nav2's semantics: leave a
circle of radius about the last baseline); here it is only asked since when it holds its
baseline. Times are integer nanoseconds (a scan's stamp), so a recorded episode replays to
the same entries bit for bit whatever the bag's start time.
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.params import ProgressObservationParams
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.planning.recovery import Pose, ProgressChecker

PREVIOUS_ACTION_LAYOUT = ("prev_wp", "prev_wc", "prev_ws", "prev_tau")
"""Names of the previous action's entries (the ``progress`` and ``history`` kinds share them)."""
PROGRESS_LAYOUT = ("stalled",) + PREVIOUS_ACTION_LAYOUT
"""Names of the entries the ``progress`` kind appends to the paper's (the kinds' registry is
``planning.observation_kinds``)."""
_NS = 1e9


class NoProgressClock:
    """Seconds since a pose last made progress, by ``ProgressChecker``'s rule.

    ``update(t_ns, pose)`` with the time (int ns) and pose (x, y, yaw) of each control step,
    in order; it returns the seconds since the baseline was last reset (0 at the first call).
    """

    def __init__(self, radius: float) -> None:
        # the window only decides ``stuck``, which nobody asks here
        self.checker = ProgressChecker(radius, float("inf"))

    def update(self, t_ns: int, pose: Pose | np.ndarray) -> float:
        t = float(int(t_ns))  # whole nanoseconds: differences are exact below 2^53 ns
        self.checker.stuck(t, (float(pose[0]), float(pose[1]), float(pose[2])))
        return (t - self.checker.since) / _NS


def previous_action_entries(
    previous: PlannerAction | None, params: ProgressObservationParams
) -> np.ndarray:
    """(4,) float64 in [0, 1]: the previous action's weights / weight_max and horizon / tau_max
    (all 0 before the first choice: no action is all zeros)."""
    out = np.zeros(len(PREVIOUS_ACTION_LAYOUT))
    if previous is not None:
        out[:3] = np.clip(np.array(previous[:3], dtype=np.float64) / params.weight_max, 0, 1)
        out[3] = min(max(previous.tau / params.tau_max, 0.0), 1.0)
    return out


def progress_features(
    stalled_s: float, previous: PlannerAction | None, params: ProgressObservationParams
) -> np.ndarray:
    """The five appended entries (5,) float64 from seconds without progress and the previous
    action (None before the first choice)."""
    stalled = min(max(stalled_s, 0.0) / params.window, 1.0)
    return np.concatenate(([stalled], previous_action_entries(previous, params)))


class ProgressObserver:
    """Turns a paper observation into the ``progress`` one, step by step: one instance per
    episode or replayed bag. ``extend`` at every observation, ``chose`` with every action the
    controller picks (not what a recovery layer drove instead)."""

    def __init__(self, params: ProgressObservationParams | None = None) -> None:
        self.params = params or ProgressObservationParams()
        self.clock = NoProgressClock(self.params.radius)
        self.previous: PlannerAction | None = None

    def extend(self, obs: np.ndarray, t_ns: int, pose: Pose | np.ndarray) -> np.ndarray:
        """obs (12,) and the estimated pose at t_ns -> (17,) float64."""
        stalled = self.clock.update(t_ns, pose)
        return np.concatenate((obs, progress_features(stalled, self.previous, self.params)))

    def chose(self, action: PlannerAction) -> None:
        self.previous = action
