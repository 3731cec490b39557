"""A live run as a ROS 2 bag (``d3dwa drive --record``), in the topics ``d3dwa record`` writes.

One set of messages per command, received at the scan's stamp (the robot's clock): the
odometry (+ ``/tf`` odom -> base_link) and, where served, wheel odometry and IMU, each with
its own header stamp; the scan; the command sent (after the clamp); the planner parameters
[wp, wc, ws, tau, action_index] (none at a blind scan's hold, where nothing was decided).
The goal and the sensor mounts are written once. After the
run, the stop is written as a zero command 1 ns after the last step. ``d3dwa replay`` and
``compare-scans`` read the bag like any recorded one; a run that fails or is interrupted
keeps every step written (the caller's ``with BagRecorder(...)`` closes it).
"""

from __future__ import annotations

from typing import Any

from d3dwa_bullet.live.link import Reading
from transfer.replay_step import StepOutput


class DriveRecorder:
    """``on_step`` hook of :func:`d3dwa_bullet.live.drive.drive` writing into a BagRecorder."""

    def __init__(self, recorder: Any) -> None:
        self.recorder = recorder
        self.last_ns: int | None = None
        """Receive time of the last step written, int ns (None before the first)."""

    def __call__(self, reading: Reading, decided: StepOutput, command: tuple[float, float]) -> None:
        rec, t = self.recorder, reading.scan.stamp_ns
        odom, wheel = reading.odometry, reading.wheel
        rec.write_odometry(t, odom.pose, odom.twist, stamp_ns=odom.stamp_ns)
        rec.write_tf(t, odom.pose)
        if wheel is not None:
            rec.write_odometry(t, wheel.pose, wheel.twist, wheel=True, stamp_ns=wheel.stamp_ns)
        if reading.imu_w is not None:
            rec.write_imu(t, reading.imu_w, stamp_ns=reading.imu_stamp_ns)
        rec.write_scan(t, reading.scan)
        rec.write_cmd(t, command)
        if decided.weights is None or decided.tau is None:  # a hold: nothing was decided
            self.last_ns = t
            return
        index = -1 if decided.action is None else decided.action
        rec.write_params(t, (*decided.weights, decided.tau, float(index)))
        self.last_ns = t

    def stopped(self) -> None:
        """Write the final stop (a zero command) after the last step, if there was one."""
        if self.last_ns is not None:
            self.recorder.write_cmd(self.last_ns + 1, (0.0, 0.0))
