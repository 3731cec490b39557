"""The fields each topic role needs from a deserialised ROS message, as plain values.

One record per message, a tuple (or list, for tf) of Python floats, strings and numpy arrays,
so the rest of the reader never touches rosbags' message classes. Malformed data raises
(any exception): the reader counts such a message as corrupt and skips it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from transfer.transforms import matrix_from_transform, yaw_from_quaternion


def stamp_ns(header: Any) -> int:
    """A std_msgs/Header's stamp as integer nanoseconds."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def decode_fields(role: str, msg: Any) -> Any:
    """The fields a role needs, as plain Python/numpy values (raises on malformed data).

    scan: (stamp, frame, angle_min, angle_increment, ranges (N,) float64, range_min,
    range_max); odometry / wheel_odometry: (stamp, frame, child frame, x, y, yaw, v, w);
    imu: (stamp, frame, w_x, w_y, w_z); tf / tf_static: [(stamp, parent, child, (4, 4))];
    goal: (stamp, frame, x, y, yaw); cmd_vel: (v, w); planner_params: (5,) float64.
    Stamps in ns, lengths in m, angles in rad, rates in m/s and rad/s.
    """
    if role == "scan":
        return (
            stamp_ns(msg.header),
            msg.header.frame_id,
            float(msg.angle_min),
            float(msg.angle_increment),
            np.asarray(msg.ranges, dtype=np.float64).copy(),
            float(msg.range_min),
            float(msg.range_max),
        )
    if role in ("odometry", "wheel_odometry"):
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        t = msg.twist.twist
        values = (
            float(p.x),
            float(p.y),
            yaw_from_quaternion(q.x, q.y, q.z, q.w),
            float(t.linear.x),
            float(t.angular.z),
        )
        if not all(math.isfinite(v) for v in values):  # would poison the interpolation
            raise ValueError(f"non-finite pose or twist {values}")
        return (stamp_ns(msg.header), msg.header.frame_id, msg.child_frame_id, *values)
    if role == "imu":
        av = msg.angular_velocity
        if not math.isfinite(av.z):
            raise ValueError(f"non-finite angular_velocity.z {av.z}")
        return (stamp_ns(msg.header), msg.header.frame_id, float(av.x), float(av.y), float(av.z))
    if role in ("tf", "tf_static"):
        out = []
        for ts in msg.transforms:
            tr, rot = ts.transform.translation, ts.transform.rotation
            mat = matrix_from_transform((tr.x, tr.y, tr.z), (rot.x, rot.y, rot.z, rot.w))
            out.append((stamp_ns(ts.header), ts.header.frame_id, ts.child_frame_id, mat))
        return out
    if role == "goal":
        p, q = msg.pose.position, msg.pose.orientation
        yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w)
        return (stamp_ns(msg.header), msg.header.frame_id, float(p.x), float(p.y), yaw)
    if role == "cmd_vel":
        return (float(msg.linear.x), float(msg.angular.z))
    if role == "planner_params":
        data = np.asarray(msg.data, dtype=np.float64)
        if data.size != 5:
            raise ValueError(f"expected 5 values [wp, wc, ws, tau, action_index], got {data.size}")
        return data.copy()
    raise KeyError(role)
