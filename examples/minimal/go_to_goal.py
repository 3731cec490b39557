"""A minimal velocity planner for the d3dwa-bullet testbed (docs/design/external-methods.md).

Each control step it looks along 19 headings from -90 to +90 degrees and takes the one closest to
the goal's bearing whose corridor (the robot's width and a margin) is free for 0.6 m; it turns
towards that heading and drives at a speed that falls with the turn still to make. With no free
heading it turns in place towards the goal. It replaces the DWA: its (v, w) goes to the robot.
"""

from __future__ import annotations

import math

import numpy as np


class GoToGoal:
    interface_version = 1
    headings = np.radians(np.arange(-90, 91, 10))
    """The headings it considers, rad, base_link (0 ahead, + to the left)."""
    half_width = 0.2
    """Half the corridor a heading needs free, m (the robot is 0.24 m wide)."""
    reach = 0.6
    """How far ahead a heading's corridor must be free, m."""

    def reset(self, episode_seed: int) -> None:
        """Nothing to reset: the rule keeps no state."""

    def command(self, inputs) -> tuple[float, float]:
        """inputs: PlannerInputs (points (M, 2) m and goal (2,) m, both in base_link: x ahead,
        y left). Returns (v m/s, w rad/s) within inputs.limits."""
        v_max, w_max = inputs.limits.v_max, inputs.limits.w_max
        goal_bearing = math.atan2(inputs.goal[1], inputs.goal[0])
        free = [self._free(inputs.points, h) for h in self.headings]
        if not any(free):
            return 0.0, math.copysign(0.5 * w_max, goal_bearing)
        choices = self.headings[np.array(free)]
        target = float(choices[np.argmin(np.abs(choices - goal_bearing))])
        w = float(np.clip(1.5 * target, -w_max, w_max))
        v = v_max * max(0.0, math.cos(target)) ** 2
        return float(min(v, math.hypot(*inputs.goal))), w  # ease in on the goal

    def _free(self, points: np.ndarray, heading: float) -> bool:
        """Whether no point (M, 2) lies in the corridor along heading, within reach."""
        c, s = math.cos(heading), math.sin(heading)
        along = points[:, 0] * c + points[:, 1] * s
        across = -points[:, 0] * s + points[:, 1] * c
        return not np.any((along > 0) & (along < self.reach) & (np.abs(across) < self.half_width))
