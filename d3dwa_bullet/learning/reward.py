"""The per-step reward R = R1 + R2 + R3 (docs/design/reward.md#reward, paper Eq. reward, r1-r3).

R1 (outcome):   r_goal                    on reaching the goal (no step penalty, as in the paper)
                r_coll + r_step           on a collision
                r_timeout + r_step        on a timeout
                r_step                    otherwise
R2 (goal):      +gc if the goal distance shrank, -gc if it grew, 0 if unchanged
R3 (obstacle):  -oc if the nearest-obstacle distance shrank, +oc if it grew, 0 if unchanged
Stall (beyond the paper, off by default): ``stall_penalty`` on a step that does not reach
                the goal and ends more than ``stall_after`` s after the robot last made
                progress (left a PROGRESS_RADIUS circle; docs/design/reward.md#stall-penalty)

Every term is multiplied by ``RewardParams.scale`` (1 for the tabular DQDWA baseline,
1/100 for the D3QN agents). R2 and R3 apply on every step, terminal ones included. The
comparisons are exact: with a noisy distance estimate a tiny change still counts, as in the
paper's definition.
"""

from __future__ import annotations

import math
from typing import Literal

from d3dwa_bullet.errors import UnknownNameError
from d3dwa_bullet.params import RewardParams

Outcome = Literal["goal", "collision", "timeout"]
OUTCOMES: tuple[str, ...] = ("goal", "collision", "timeout")


def _sign(before: float, after: float, what: str) -> int:
    """+1 if ``after`` < ``before`` (the distance shrank), -1 if it grew, 0 if equal."""
    if math.isnan(before) or math.isnan(after):
        raise ValueError(f"reward: {what} distance is NaN (before={before!r}, after={after!r})")
    return (after < before) - (after > before)


def reward(
    outcome: Outcome | None,
    d_goal_prev: float,
    d_goal: float,
    d_obs_prev: float,
    d_obs: float,
    params: RewardParams,
    stalled_s: float = 0.0,
) -> float:
    """The reward of one control step.

    outcome: None (episode continues), "goal", "collision" or "timeout".
    d_goal_prev, d_goal: goal distance before / after the step, m.
    d_obs_prev, d_obs: distance to the nearest obstacle before / after the step, m
        (``inf`` when nothing is in range; two ``inf`` compare equal).
    stalled_s: seconds since the robot last made progress, at the end of the step (ground
        truth, like the distances); only read when ``params.stall_penalty`` is not 0.
    Raises UnknownNameError for any other outcome and ValueError for a NaN distance.
    """
    if outcome is None:
        r1 = params.step
    elif outcome == "goal":
        r1 = params.goal
    elif outcome == "collision":
        r1 = params.collision + params.step
    elif outcome == "timeout":
        r1 = params.timeout + params.step
    else:
        raise UnknownNameError(
            f"reward: unknown outcome {outcome!r}, expected None or one of {OUTCOMES}"
        )
    if outcome != "goal" and params.stall_penalty and stalled_s > params.stall_after:
        r1 += params.stall_penalty
    r2 = params.goal_shaping * _sign(d_goal_prev, d_goal, "goal")
    r3 = -params.obstacle_shaping * _sign(d_obs_prev, d_obs, "obstacle")
    return float(params.scale * (r1 + r2 + r3))
