"""A velocity command in place of the DWA: what a velocity planner reads and how its (v, w)
becomes a planning step (docs/design/external-methods.md#external-methods).

A controller may carry a local planner of its own (``Controller.velocity``): a callable from
:class:`PlannerInputs` to (v m/s, w rad/s). The episode, the bag replay and the live loop
then step with ``episode.step_plan``, which calls it where they would call the DWA;
everything around it (the scan filter, the estimator, the recovery layer, the robot's
limits) stays.

Pure: numpy only; the types alone (importing them does not load the planner's kernels).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.params import RobotLimits
from d3dwa_bullet.planning.actions import PlannerAction


@dataclass(frozen=True)
class PlannerInputs:
    """What a velocity planner is given at one control step; every array is its own copy.

    points: (M, 2) float64, the filtered scan's valid returns, m, base_link; pose: (3,)
    float64 estimated [x m, y m, yaw rad] in the world (odometry) frame; velocity: (2,)
    float64 estimated [v m/s, w rad/s]; goal: (2,) float64 goal in base_link, m; limits:
    the robot's velocity and acceleration limits; control_period: s, the time one command
    is held (and the budget of one call, unless the method declares its own ``budget_s``).
    """

    points: np.ndarray
    pose: np.ndarray
    velocity: np.ndarray
    goal: np.ndarray
    limits: RobotLimits
    control_period: float


#: A local planner: inputs -> (v m/s, w rad/s).
LocalPlanner = Callable[[PlannerInputs], tuple[float, float]]

#: The action a velocity planner's steps log: it chooses no DWA parameters (NaN weights and
#: horizon, index -1 as a fixed method's).
NO_PARAMETERS = PlannerAction(float("nan"), float("nan"), float("nan"), float("nan"))
