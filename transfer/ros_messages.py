"""The Kachaka bridge's ROS messages, built as instances of one rosbags typestore.

``MessageBuilder`` knows ROS 1 from ROS 2 only where the message layouts differ (the
``seq`` field of ROS 1 headers); serialising and writing is ``transfer.bag_writer``'s job.
Lengths in m, angles in rad, rates in m/s and rad/s, stamps in integer ns.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from d3dwa_bullet.sim.scan import LaserScan
from transfer.topics import (
    FLOAT64_ARRAY,
    IMU,
    LASER_SCAN,
    ODOMETRY,
    POSE_STAMPED,
    TF_MESSAGE,
    TWIST,
)
from transfer.transforms import quaternion_from_yaw


@functools.cache
def default_typestore(ros1: bool) -> Any:
    """ROS 1 Noetic or ROS 2 Humble message types, built once per process (building is slow)."""
    # rosbags takes ~0.1 s to import; every `d3dwa` command imports transfer, few write a bag.
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if TF_MESSAGE not in store.types:  # the ROS 1 store ships without tf2_msgs
        store.register(
            get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TF_MESSAGE)
        )
    return store


class MessageBuilder:
    """Message instances of ``typestore``; ros1 selects the ROS 1 header layout."""

    def __init__(self, typestore: Any, ros1: bool) -> None:
        self.typestore = typestore
        self.ros1 = ros1
        self._types = typestore.types

    def message(self, msgtype: str, **fields: Any) -> Any:
        """Any message type of the typestore, from its fields."""
        return self._types[msgtype](**fields)

    def header(self, stamp_ns: int, frame: str) -> Any:
        """std_msgs/Header at stamp_ns in frame."""
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        stamp = self.message("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)
        if self.ros1:
            return self.message("std_msgs/msg/Header", seq=0, stamp=stamp, frame_id=frame)
        return self.message("std_msgs/msg/Header", stamp=stamp, frame_id=frame)

    def vector3(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
        return self.message("geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=float(z))

    def quaternion(self, yaw: float) -> Any:
        """A rotation by yaw about z that decodes back to the same float64 yaw."""
        x, y, z, w = quaternion_from_yaw(yaw)
        return self.message("geometry_msgs/msg/Quaternion", x=x, y=y, z=z, w=w)

    def pose(self, x: float, y: float, yaw: float) -> Any:
        """geometry_msgs/Pose at (x, y, 0) with heading yaw."""
        position = self.message("geometry_msgs/msg/Point", x=float(x), y=float(y), z=0.0)
        return self.message(
            "geometry_msgs/msg/Pose", position=position, orientation=self.quaternion(yaw)
        )

    def transform(self, t_ns: int, parent: str, child: str, xyz: tuple, yaw: float) -> Any:
        """geometry_msgs/TransformStamped: child at xyz, turned by yaw, in parent."""
        tf = self.message(
            "geometry_msgs/msg/Transform",
            translation=self.vector3(*xyz),
            rotation=self.quaternion(yaw),
        )
        return self.message(
            "geometry_msgs/msg/TransformStamped",
            header=self.header(t_ns, parent),
            child_frame_id=child,
            transform=tf,
        )

    def tf_message(self, transforms: list[Any]) -> Any:
        """tf2_msgs/TFMessage of TransformStamped messages."""
        return self.message(TF_MESSAGE, transforms=transforms)

    def goal(self, t_ns: int, frame: str, x: float, y: float) -> Any:
        """geometry_msgs/PoseStamped at (x, y), heading 0, in frame."""
        return self.message(
            POSE_STAMPED, header=self.header(t_ns, frame), pose=self.pose(x, y, 0.0)
        )

    def scan(self, stamp_ns: int, frame: str, scan: LaserScan) -> Any:
        """sensor_msgs/LaserScan of a scan (ranges as float32, no intensities)."""
        n = scan.ranges.size
        return self.message(
            LASER_SCAN,
            header=self.header(stamp_ns, frame),
            angle_min=float(scan.angle_min),
            angle_max=float(scan.angle_min + (n - 1) * scan.angle_increment),
            angle_increment=float(scan.angle_increment),
            time_increment=0.0,
            scan_time=0.0,
            range_min=float(scan.range_min),
            range_max=float(scan.range_max),
            ranges=scan.ranges.astype(np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )

    def twist(self, v: float, w: float) -> Any:
        """geometry_msgs/Twist: linear.x = v, angular.z = w."""
        return self.message(TWIST, linear=self.vector3(v), angular=self.vector3(z=w))

    def odometry(
        self,
        stamp_ns: int,
        frame: str,
        child: str,
        pose: tuple | np.ndarray,
        twist: tuple | np.ndarray,
    ) -> Any:
        """nav_msgs/Odometry: pose (x, y, yaw) in frame, twist (v, w) in child; zero covariances."""
        x, y, yaw = (float(v) for v in pose)
        v, w = (float(u) for u in twist)
        cov = np.zeros(36)
        return self.message(
            ODOMETRY,
            header=self.header(stamp_ns, frame),
            child_frame_id=child,
            pose=self.message(
                "geometry_msgs/msg/PoseWithCovariance", pose=self.pose(x, y, yaw), covariance=cov
            ),
            twist=self.message(
                "geometry_msgs/msg/TwistWithCovariance",
                twist=self.twist(v, w),
                covariance=cov.copy(),
            ),
        )

    def imu(self, stamp_ns: int, frame: str, gyro_w: float) -> Any:
        """sensor_msgs/Imu with angular_velocity.z = gyro_w; no orientation estimate."""
        no_orientation = np.zeros(9)
        no_orientation[0] = -1.0  # sensor_msgs/Imu convention: orientation not provided
        return self.message(
            IMU,
            header=self.header(stamp_ns, frame),
            orientation=self.message("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=no_orientation,
            angular_velocity=self.vector3(z=gyro_w),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=self.vector3(),
            linear_acceleration_covariance=np.zeros(9),
        )

    def planner_params(self, data: np.ndarray) -> Any:
        """std_msgs/Float64MultiArray of the 5 values [wp, wc, ws, tau, action_index]."""
        dim = self.message(
            "std_msgs/msg/MultiArrayDimension", label="wp_wc_ws_tau_action", size=5, stride=5
        )
        layout = self.message("std_msgs/msg/MultiArrayLayout", dim=[dim], data_offset=0)
        return self.message(FLOAT64_ARRAY, layout=layout, data=data)
