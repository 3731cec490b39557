"""Kachaka API messages <-> this package's records: scans, odometry, IMU, velocity commands.

Every field the loop reads is a protobuf ``double``, so a simulated scan (already rounded to
float32, as ``sensor_msgs/LaserScan`` stores it), a pose and a twist cross the wire bit for
bit. Two encodings need care to stay exact:

* yaw travels as a quaternion: :func:`transfer.transforms.quaternion_from_yaw` picks the one
  that decodes to the same float64 (as a recorded bag does);
* ``SetRobotVelocity`` carries the command as a fraction of the robot's maximum
  (``linear = v / MAX_LINEAR_VELOCITY``, as ``KachakaApiClientBase`` sends it); the fraction
  is nudged by a few ulp so that the robot's ``linear * MAX`` gives back v exactly where such
  a fraction exists (:func:`encode_fraction`). For about one command value in six none does
  (fractions of 0.3 are spaced wider than the ulp of v): the robot then decodes v within one
  ulp (< 1e-16 m/s). Physics amplifies such a difference (R1, dwa3: the paths part after
  16 steps and the goal is reached in 249 steps instead of 255), so the exact command rides
  along as gRPC call metadata (``COMMAND_METADATA``, float.hex of v and w): the simulated
  Kachaka applies it when it agrees with the fractions to 1e-12, and a real Kachaka ignores
  metadata it does not know (docs/design/live.md#live).

Stamps are the messages' ``header.stamp_nsec`` (int ns, the robot's clock); 0 means unset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from kachaka_api.base import MAX_ANGULAR_VELOCITY, MAX_LINEAR_VELOCITY
from kachaka_api.generated import kachaka_api_pb2 as pb2

from d3dwa_bullet.sim.scan import LaserScan
from transfer.transforms import quaternion_from_yaw, yaw_from_quaternion

#: Frame names the simulated Kachaka writes into its headers (those of a recorded bag).
ODOM_FRAME, BASE_FRAME, LIDAR_FRAME, IMU_FRAME = "odom", "base_link", "lidar_link", "imu_link"
_MAX_NUDGE_ULP = 4
COMMAND_METADATA = "d3dwa-command"
"""gRPC metadata key of a velocity command's exact (v, w): "float.hex(v) float.hex(w)"."""
_AGREE = 1e-12  # how close the exact command must be to the decoded fractions

Pose = tuple[float, float, float]
Twist = tuple[float, float]


@dataclass(frozen=True)
class Odometry:
    """One odometry reading: pose (x, y, yaw) m/rad in the odometry frame, twist (v, w) m/s,
    rad/s in base_link, stamp_ns the robot's int ns (0: unset)."""

    pose: Pose
    twist: Twist
    stamp_ns: int


def scan_message(scan: LaserScan, frame: str = LIDAR_FRAME) -> pb2.RosLaserScan:
    """A RosLaserScan of a scan record, stamped with its stamp_ns."""
    n = scan.ranges.size
    return pb2.RosLaserScan(
        header=pb2.RosHeader(stamp_nsec=int(scan.stamp_ns), frame_id=frame),
        angle_min=scan.angle_min,
        angle_max=scan.angle_min + (n - 1) * scan.angle_increment,
        angle_increment=scan.angle_increment,
        range_min=scan.range_min,
        range_max=scan.range_max,
        ranges=scan.ranges.tolist(),
    )


def scan_from_message(msg: pb2.RosLaserScan) -> LaserScan:
    """The scan record of a RosLaserScan (ScanError if it has no beams or bad geometry)."""
    return LaserScan(
        angle_min=msg.angle_min,
        angle_increment=msg.angle_increment,
        ranges=np.asarray(msg.ranges, dtype=np.float64),
        range_min=msg.range_min,
        range_max=msg.range_max,
        stamp_ns=int(msg.header.stamp_nsec),
    )


def odometry_message(
    pose: Pose, twist: Twist, stamp_ns: int, frame: str = ODOM_FRAME, child: str = BASE_FRAME
) -> pb2.RosOdometry:
    """A RosOdometry at pose (x, y, yaw) with body twist (v, w)."""
    qx, qy, qz, qw = quaternion_from_yaw(pose[2])
    return pb2.RosOdometry(
        header=pb2.RosHeader(stamp_nsec=int(stamp_ns), frame_id=frame),
        child_frame_id=child,
        pose=pb2.Pose3dWithCovariance(
            pose=pb2.Pose3d(
                position=pb2.Vector3(x=pose[0], y=pose[1], z=0.0),
                orientation=pb2.Quaternion(x=qx, y=qy, z=qz, w=qw),
            )
        ),
        twist=pb2.TwistWithCovariance(
            twist=pb2.Twist(linear=pb2.Vector3(x=twist[0]), angular=pb2.Vector3(z=twist[1]))
        ),
    )


def odometry_from_message(msg: pb2.RosOdometry) -> Odometry:
    """The planar pose, body twist and stamp of a RosOdometry."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    t = msg.twist.twist
    yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w) if (q.x, q.y, q.z, q.w) != (0, 0, 0, 0) else 0.0
    return Odometry((p.x, p.y, yaw), (t.linear.x, t.angular.z), int(msg.header.stamp_nsec))


def imu_message(gyro_w: float, stamp_ns: int, frame: str = IMU_FRAME) -> pb2.RosImu:
    """A RosImu with only the yaw rate (angular_velocity.z, rad/s); orientation unknown (-1)."""
    return pb2.RosImu(
        header=pb2.RosHeader(stamp_nsec=int(stamp_ns), frame_id=frame),
        orientation_covariance=[-1.0] + [0.0] * 8,
        angular_velocity=pb2.Vector3(z=gyro_w),
    )


def encode_fraction(value: float, scale: float) -> float:
    """value / scale, nudged by at most a few ulp so that ``fraction * scale == value``
    where such a fraction exists (else the plain quotient)."""
    fraction = value / scale
    for k in range(_MAX_NUDGE_ULP + 1):
        for direction in (math.inf, -math.inf) if k else (0.0,):
            f = fraction
            for _ in range(k):
                f = math.nextafter(f, direction)
            if f * scale == value:
                return f
    return fraction


def velocity_request(v: float, w: float) -> pb2.SetRobotVelocityRequest:
    """The SetRobotVelocity request of (v m/s, w rad/s), fractions of the robot's maxima."""
    return pb2.SetRobotVelocityRequest(
        linear=encode_fraction(v, MAX_LINEAR_VELOCITY),
        angular=encode_fraction(w, MAX_ANGULAR_VELOCITY),
    )


def velocity_of(request: pb2.SetRobotVelocityRequest) -> Twist:
    """(v, w) of a SetRobotVelocity request, as the robot decodes it."""
    return request.linear * MAX_LINEAR_VELOCITY, request.angular * MAX_ANGULAR_VELOCITY


def command_metadata(v: float, w: float) -> tuple[tuple[str, str], ...]:
    """The call metadata carrying (v, w) exactly, for :func:`command_of`."""
    return ((COMMAND_METADATA, f"{float(v).hex()} {float(w).hex()}"),)


def command_of(request: pb2.SetRobotVelocityRequest, metadata: Any) -> Twist:
    """(v, w) of a SetRobotVelocity call: the exact command from the call's metadata when it
    agrees with the request's fractions (to 1e-12), else the decoded fractions."""
    decoded = velocity_of(request)
    text = dict(metadata or ()).get(COMMAND_METADATA)
    if not isinstance(text, str):
        return decoded
    try:
        v, w = (float.fromhex(part) for part in text.split())
    except ValueError:
        return decoded
    if abs(v - decoded[0]) <= _AGREE and abs(w - decoded[1]) <= _AGREE:
        return v, w
    return decoded
