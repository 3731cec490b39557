"""What the replay hands a step function at each scan, and what it takes back.

All per-scan processing goes through ONE injectable step function::

    step_fn(step: ScanStep) -> StepOutput | Mapping[str, Any]

``observe_only`` (the default) builds the 12-d observation from the recorded odometry; the
full pipeline (``transfer.sim_bridge.make_step_fn``) takes the recorded odometry (or
re-fuses wheel odometry and gyro) as the estimate, asks the policy for an action and the
planner for a command, with the simulator's own code. A step function may raise
``SkipScan(reason)`` to skip a scan it cannot use; it is counted like the reader's skips.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from d3dwa_bullet.planning.observation import build_observation
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body

#: Pose sources of a decision step (``d3dwa replay --estimator``): the bag's fused odometry,
#: or its wheel odometry and gyro re-fused by the simulator's EKF (``transfer.sim_bridge``).
Estimator = Literal["odometry", "ekf"]
ESTIMATORS: tuple[str, ...] = ("odometry", "ekf")


@dataclass(frozen=True)
class ScanStep:
    """What is known at one scan time; the step function's only input.

    t_ns: replay-clock time, int ns. odom_pose: (3,) [x m, y m, yaw rad] and odom_twist:
    (2,) [v m/s, w rad/s] from the bag's odometry interpolated to t_ns; wheel_twist the same
    from wheel odometry (None if absent); imu_w: gyro yaw rate, rad/s (None if no IMU sample
    brackets t_ns); goal: (2,) m, odometry frame; mount: lidar pose in base_link.
    """

    t_ns: int
    scan: LaserScan
    mount: Pose2D
    odom_pose: np.ndarray
    odom_twist: np.ndarray
    goal: np.ndarray
    wheel_twist: np.ndarray | None = None
    imu_w: float | None = None

    def points(self) -> np.ndarray:
        """Valid returns in base_link: (M, 2) float64, m."""
        return scan_points_body(self.scan, self.mount)


@dataclass(frozen=True)
class StepOutput:
    """What the step function decided at one scan.

    observation: (12,) float64; pose: (3,) estimated [x, y, yaw]; velocity: (2,) estimated
    [v, w]; action: index into the action set; weights: (wp, wc, ws); tau: horizon, s;
    cmd: planner command (v m/s, w rad/s). Unused fields stay None.
    """

    observation: np.ndarray
    pose: tuple[float, float, float] | np.ndarray
    velocity: tuple[float, float] | np.ndarray
    action: int | None = None
    weights: tuple[float, float, float] | None = None
    tau: float | None = None
    cmd: tuple[float, float] | None = None


StepFn = Callable[[ScanStep], StepOutput | Mapping[str, Any]]
"""A step function may carry an ``observation_layout`` (tuple of entry names) when its
observation is not the paper's 12 entries; replay.csv then has a column per entry."""


class SkipScan(Exception):
    """Raised by a step function to skip one scan; counted in ``skipped`` under ``reason``."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def observe_only(step: ScanStep) -> StepOutput:
    """Default step: the observation from the recorded odometry, no decision."""
    obs = build_observation(step.odom_pose, step.odom_twist, step.goal, step.points())
    return StepOutput(observation=obs, pose=step.odom_pose, velocity=step.odom_twist)
