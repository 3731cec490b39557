"""Follow the gap: steer for the free bearing nearest the goal's, slow down near obstacles.

Every control step the scan's points (base_link, m) block the bearings they would cover once
grown by the robot's radius; the free bearings in front form gaps. The planner heads for the
goal's bearing when it is free, else for the free bearing closest to it, and turns on the
spot when nothing in front is free. Speed falls with the heading error and with the nearest
obstacle ahead. It implements the testbed's velocity planner interface, version 1
(d3dwa-bullet docs/design/external-methods.md#external-methods): ``reset(seed)`` and ``command(inputs)``.
"""

from __future__ import annotations

import math

import numpy as np


class FollowTheGap:
    """A velocity planner: the filtered scan, the estimate and the goal in, (v, w) out."""

    interface_version = 1
    bearings = np.linspace(-math.pi / 2, math.pi / 2, 91)
    """The bearings it can head for, rad, base_link (2 degrees apart)."""
    radius = 0.30
    """The robot's half-diagonal and a margin, m: how far a point blocks bearings around it."""
    lookahead = 1.2
    """Points farther than this do not block a bearing, m."""
    slow_distance = 0.8
    """Ahead of an obstacle closer than this, the speed falls in proportion, m."""
    turn_gain = 1.5
    """Angular velocity per radian of heading error, 1/s."""

    def reset(self, episode_seed: int) -> None:
        """Nothing to reset: the planner keeps no state between steps."""

    def command(self, inputs) -> tuple[float, float]:
        """(v m/s, w rad/s) from inputs.points (M, 2), inputs.goal (2,) in base_link (m) and
        inputs.limits (v_max, w_max)."""
        v_max, w_max = inputs.limits.v_max, inputs.limits.w_max
        goal = np.asarray(inputs.goal, dtype=float)
        goal_bearing = math.atan2(goal[1], goal[0])
        goal_distance = math.hypot(goal[0], goal[1])
        points = np.asarray(inputs.points, dtype=float).reshape(-1, 2)
        distance = np.hypot(points[:, 0], points[:, 1])
        near = (distance < self.lookahead) & (distance > 1e-6)
        bearing = np.arctan2(points[near, 1], points[near, 0])
        half_width = np.arcsin(np.minimum(1.0, self.radius / distance[near]))
        gap = np.abs(_wrap(self.bearings[:, None] - bearing[None, :]))
        free = ~(gap < half_width[None, :]).any(axis=1)
        if abs(goal_bearing) <= math.pi / 2 and _free_at(self.bearings, free, goal_bearing):
            target = goal_bearing
        elif free.any():
            choices = self.bearings[free]
            target = float(choices[np.argmin(np.abs(_wrap(choices - goal_bearing)))])
        else:  # nothing in front is free: turn on the spot towards the goal's side
            return 0.0, math.copysign(0.5 * w_max, goal_bearing)
        w = float(np.clip(self.turn_gain * target, -w_max, w_max))
        ahead = near & (np.abs(points[:, 1]) < self.radius) & (points[:, 0] > 0)
        nearest = float(distance[ahead].min()) if ahead.any() else math.inf
        v = v_max * max(0.0, math.cos(target)) * min(1.0, nearest / self.slow_distance)
        v = min(v, goal_distance)  # ease in on the goal: 1 m/s per m left
        return float(np.clip(v, 0.0, v_max)), w


def _wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def _free_at(bearings: np.ndarray, free: np.ndarray, bearing: float) -> bool:
    return bool(free[int(np.argmin(np.abs(bearings - bearing)))])
