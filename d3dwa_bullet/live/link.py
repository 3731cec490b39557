"""The Kachaka client adapter: what the live loop reads and sends, each call with a deadline.

It speaks the official service (``kachaka_api``'s generated ``KachakaApiStub``) and encodes
requests as ``KachakaApiClientBase`` does, but calls the stub itself: the client's methods
take no deadline, and a robot that stops answering must never stall the loop (a call that
misses ``timeout`` is a :class:`RobotLinkError`, which ends the run with a stop). The four
reads of a step go out together (gRPC futures), so a step costs one round trip, not four.

Reads: the scan and the fused odometry are required; wheel odometry and IMU are used where
the robot serves them (an unimplemented call or an empty message reads None). Commands go
out as ``set_robot_velocity`` does: if the robot refuses one (manual control is off), manual
control is enabled and the command sent again. :meth:`stop` is the robot client's
``set_robot_stop`` (zero velocity, manual control off) and never raises.
"""

from __future__ import annotations

import importlib.metadata
import re
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

import grpc
from kachaka_api.generated import kachaka_api_pb2 as pb2
from kachaka_api.generated.kachaka_api_pb2_grpc import KachakaApiStub

from d3dwa_bullet.errors import ConfigError, RobotLinkError, ScanError
from d3dwa_bullet.live.messages import (
    Odometry,
    command_metadata,
    odometry_from_message,
    scan_from_message,
    velocity_request,
)
from d3dwa_bullet.sim.scan import LaserScan

DEFAULT_PORT = 26400
"""The Kachaka API's gRPC port."""
_TARGET = re.compile(r"^(?P<host>\[[0-9a-fA-F:.]+\]|[^:\s]+)(?::(?P<port>\d+))?$")


def parse_target(text: str) -> str:
    """'HOST' or 'HOST:PORT' (IPv6 in brackets) -> 'HOST:PORT'; ConfigError naming --kachaka."""
    match = _TARGET.match(text.strip())
    port = int(match["port"]) if match and match["port"] else DEFAULT_PORT
    if match is None or not 0 < port < 65536:
        raise ConfigError(f"--kachaka must be HOST or HOST:PORT (port 1-65535), got {text!r}")
    return f"{match['host']}:{port}"


def api_version() -> str:
    """The installed kachaka-api package's version (what a robot of its release answers)."""
    return importlib.metadata.version("kachaka-api")


def api_major() -> str:
    """The major version of the installed kachaka-api: robots of that major speak the
    service this adapter was written against."""
    return api_version().split(".")[0]


@dataclass(frozen=True)
class Reading:
    """What the robot served at one step: the scan, its fused odometry, and where served
    its wheel odometry and gyro yaw rate (rad/s) with its stamp (int ns)."""

    scan: LaserScan
    odometry: Odometry
    wheel: Odometry | None = None
    imu_w: float | None = None
    imu_stamp_ns: int = 0


class KachakaLink:
    """A connection to one Kachaka (or ``d3dwa serve``), opened within connect_timeout (s).

    timeout: deadline of every later call, s. RobotLinkError when the robot cannot be
    reached, a call fails or misses its deadline.
    """

    def __init__(self, target: str, *, timeout: float = 0.5, connect_timeout: float = 3.0):
        self.address = parse_target(target)
        self.timeout = timeout
        self.channel = grpc.insecure_channel(self.address)
        try:
            grpc.channel_ready_future(self.channel).result(timeout=connect_timeout)
        except grpc.FutureTimeoutError as err:
            self.channel.close()
            raise RobotLinkError(
                f"cannot reach a Kachaka at {self.address} within {connect_timeout:g} s "
                "(is the robot on, and the host and port right?); nothing was sent"
            ) from err
        self.stub = KachakaApiStub(self.channel)
        self.commands = 0
        """Velocity commands the robot accepted."""

    def _call(self, method: Any, request: Any, what: str) -> Any:
        try:
            return method(request, timeout=self.timeout)
        except grpc.RpcError as err:
            raise _link_error(self.address, what, err) from err

    def version(self) -> str:
        """The robot's software version (GetRobotVersion)."""
        return self._call(self.stub.GetRobotVersion, pb2.GetRequest(), "GetRobotVersion").version

    def serial(self) -> str:
        """The robot's serial number (GetRobotSerialNumber)."""
        return self._call(
            self.stub.GetRobotSerialNumber, pb2.GetRequest(), "GetRobotSerialNumber"
        ).serial_number

    def check_version(self) -> str:
        """The robot's version, RobotLinkError unless its major is this kachaka-api's."""
        version = self.version()
        if version.split(".")[0] != api_major():
            raise RobotLinkError(
                f"{self.address} runs Kachaka API version {version!r}; this client speaks "
                f"major version {api_major()} (kachaka-api {api_version()})"
            )
        return version

    def robot_pose(self) -> tuple[float, float, float]:
        """The robot's pose on its map (GetRobotPose): x, y m, theta rad, map frame."""
        pose = self._call(self.stub.GetRobotPose, pb2.GetRequest(), "GetRobotPose").pose
        return pose.x, pose.y, pose.theta

    def map(self) -> Any:
        """The robot's current map (GetPngMap), or None where the robot serves none."""
        try:
            # a map is one PNG, far larger than a step's messages: it gets a longer deadline
            return self.stub.GetPngMap(pb2.GetRequest(), timeout=max(self.timeout, 5.0)).map
        except grpc.RpcError as err:
            if err.code() == grpc.StatusCode.UNIMPLEMENTED:  # type: ignore[attr-defined]
                return None
            raise _link_error(self.address, "GetPngMap", err) from err

    def read(self) -> Reading:
        """One step's readings; RobotLinkError if the scan or the odometry is missing."""
        stub, request = self.stub, pb2.GetRequest()
        calls = {
            "GetRosLaserScan": stub.GetRosLaserScan.future(request, timeout=self.timeout),
            "GetRosOdometry": stub.GetRosOdometry.future(request, timeout=self.timeout),
            "GetRosWheelOdometry": stub.GetRosWheelOdometry.future(request, timeout=self.timeout),
            "GetRosImu": stub.GetRosImu.future(request, timeout=self.timeout),
        }
        scan_msg = self._result(calls["GetRosLaserScan"], "GetRosLaserScan").scan
        odom_msg = self._result(calls["GetRosOdometry"], "GetRosOdometry").odometry
        wheel = self._optional(calls["GetRosWheelOdometry"], "GetRosWheelOdometry")
        imu = self._optional(calls["GetRosImu"], "GetRosImu")
        if not scan_msg.ranges or not scan_msg.header.stamp_nsec:
            raise RobotLinkError(f"{self.address} serves no laser scan (an empty message)")
        if not odom_msg.header.stamp_nsec:
            raise RobotLinkError(f"{self.address} serves no odometry (an empty message)")
        try:
            scan = scan_from_message(scan_msg)
        except ScanError as err:
            raise RobotLinkError(f"{self.address} serves an unusable laser scan: {err}") from err
        wheel_odom = None
        if wheel is not None and wheel.odometry.header.stamp_nsec:
            wheel_odom = odometry_from_message(wheel.odometry)
        imu_w, imu_stamp = None, 0
        if imu is not None and imu.imu.header.stamp_nsec:
            imu_w, imu_stamp = imu.imu.angular_velocity.z, int(imu.imu.header.stamp_nsec)
        return Reading(scan, odometry_from_message(odom_msg), wheel_odom, imu_w, imu_stamp)

    def _result(self, future: Future, what: str) -> Any:
        try:
            return future.result()
        except grpc.RpcError as err:
            raise _link_error(self.address, what, err) from err

    def _optional(self, future: Future, what: str) -> Any:
        try:
            return future.result()
        except grpc.RpcError as err:
            if err.code() == grpc.StatusCode.UNIMPLEMENTED:  # type: ignore[attr-defined]
                return None
            raise _link_error(self.address, what, err) from err

    def command(self, v: float, w: float) -> None:
        """Send (v m/s, w rad/s) as ``set_robot_velocity`` does (enabling manual control
        once if the robot refuses); RobotLinkError if it is still refused."""
        request, exact = velocity_request(v, w), command_metadata(v, w)
        result = self._send(request, exact)
        if not result.success:
            self._call(
                self.stub.SetManualControlEnabled,
                pb2.SetManualControlEnabledRequest(enable=True),
                "SetManualControlEnabled",
            )
            result = self._send(request, exact)
            if not result.success:
                raise RobotLinkError(
                    f"{self.address} refused a velocity command (error code {result.error_code})"
                )
        self.commands += 1

    def _send(self, request: Any, exact: Any) -> Any:
        try:
            return self.stub.SetRobotVelocity(request, timeout=self.timeout, metadata=exact).result
        except grpc.RpcError as err:
            raise _link_error(self.address, "SetRobotVelocity", err) from err

    def stop(self) -> bool:
        """``set_robot_stop``: zero velocity, then manual control off. True if the robot
        answered (a robot that refuses the zero velocity has manual control off: nothing
        drives it); never raises (a lost robot returns False)."""
        try:
            self.stub.SetRobotVelocity(
                velocity_request(0.0, 0.0), timeout=self.timeout,
                metadata=command_metadata(0.0, 0.0),
            )  # fmt: skip
        except grpc.RpcError:
            return False
        try:
            self.stub.SetManualControlEnabled(
                pb2.SetManualControlEnabledRequest(enable=False), timeout=self.timeout
            )
        except grpc.RpcError:
            pass
        return True

    def close(self) -> None:
        self.channel.close()


def _link_error(address: str, what: str, err: grpc.RpcError) -> RobotLinkError:
    code = err.code()  # type: ignore[attr-defined]
    if code == grpc.StatusCode.DEADLINE_EXCEEDED:
        return RobotLinkError(f"{address}: {what} got no answer in time (deadline exceeded)")
    if code == grpc.StatusCode.UNAVAILABLE:
        return RobotLinkError(
            f"{address}: {what} failed: the robot is unreachable (connection lost)"
        )
    details = err.details() or ""  # type: ignore[attr-defined]
    return RobotLinkError(
        f"{address}: {what} failed: {code.name}{': ' + details if details else ''}"
    )
