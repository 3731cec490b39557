"""The contract the robot's sensors start with, held at every step (issue 31): a scan that
goes blind or changes its layout mid-run, or odometry that stops making sense, ends the run
with a stop as the last command and one line, never a drive on what the robot cannot see."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from kachaka_api.generated import kachaka_api_pb2 as pb2  # noqa: E402

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.errors import RobotLinkError, ScanError  # noqa: E402
from d3dwa_bullet.live import (  # noqa: E402
    DriveResult,
    DriveSettings,
    KachakaLink,
    Reading,
    SimulatedKachaka,
    drive,
)
from d3dwa_bullet.live.messages import Odometry  # noqa: E402
from d3dwa_bullet.live.safety import (  # noqa: E402
    BLIND_SCANS,
    MIN_READING_FRACTION,
    OdometryCheck,
    ScanContract,
)
from d3dwa_bullet.params import ObservationParams  # noqa: E402
from d3dwa_bullet.sim.lidar_params import LidarParams  # noqa: E402
from d3dwa_bullet.sim.scan import LaserScan  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.learning.test_onnx_guard import nan_on_a_free_sector  # noqa: E402
from tests.support.cli import refused  # noqa: E402
from transfer.sim_bridge import ReplayPipeline  # noqa: E402

PATIENT = ("--lockstep", "--watchdog", "60", "--timeout", "30")
LIDAR = LidarParams()
BAD_AFTER = 5
"""Snapshots served well before a robot's sensor goes bad."""


def _ranges(msg: pb2.RosLaserScan, values: list[float]) -> pb2.RosLaserScan:
    bad = pb2.RosLaserScan()
    bad.CopyFrom(msg)
    del bad.ranges[:]
    bad.ranges.extend(values)
    return bad


def _narrower(msg: pb2.RosLaserScan, keep: slice) -> pb2.RosLaserScan:
    """The beams ``keep`` only: a field of view that shrinks with the beam count."""
    bad = _ranges(msg, list(msg.ranges)[keep])
    bad.angle_min = msg.angle_min + (keep.start or 0) * msg.angle_increment
    bad.angle_max = bad.angle_min + (len(bad.ranges) - 1) * msg.angle_increment
    return bad


def _squeezed(msg: pb2.RosLaserScan) -> pb2.RosLaserScan:
    """As many beams over half the field of view (a driver reconfigured mid-run)."""
    bad = _ranges(msg, list(msg.ranges))
    bad.angle_min, bad.angle_increment = 0.5 * msg.angle_min, 0.5 * msg.angle_increment
    bad.angle_max = bad.angle_min + (len(bad.ranges) - 1) * bad.angle_increment
    return bad


CORRUPTIONS = {
    "nan": lambda m: _ranges(m, [math.nan] * len(m.ranges)),
    "negative": lambda m: _ranges(m, [-1.0] * len(m.ranges)),
    "zero": lambda m: _ranges(m, [0.0] * len(m.ranges)),
    "two-thirds-nan": lambda m: _ranges(
        m, [math.nan if i % 3 else r for i, r in enumerate(m.ranges)]
    ),
    "one-side-dark": lambda m: _ranges(
        m, [math.nan if i < len(m.ranges) // 3 else r for i, r in enumerate(m.ranges)]
    ),
    "narrower": lambda m: _narrower(m, slice(120, 361)),
    "squeezed": _squeezed,
}
BLIND = {"nan", "negative", "zero", "two-thirds-nan", "one-side-dark"}


class BadScan(SimulatedKachaka):
    """A robot whose scan goes bad (``corrupt``) from snapshot BAD_AFTER + 1 on; records how
    many commands it had received, and when (monotonic s), at its first bad scan."""

    corrupt = staticmethod(CORRUPTIONS["nan"])

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.bad_from: int | None = None
        self.bad_since: float | None = None
        self.times: list[tuple[float, float, float]] = []  # (monotonic s, v, w) per command

    def GetRosLaserScan(self, request, context):  # noqa: N802
        response = super().GetRosLaserScan(request, context)
        if self.cursor > BAD_AFTER:
            if self.bad_from is None:
                self.bad_from, self.bad_since = len(self.received), time.monotonic()
            response.scan.CopyFrom(self.corrupt(response.scan))
        return response

    def SetRobotVelocity(self, request, context):  # noqa: N802
        response = super().SetRobotVelocity(request, context)
        if response.result.success or (request.linear, request.angular) == (0.0, 0.0):
            self.times.append((time.monotonic(), request.linear, request.angular))
        return response


def drive_args(address: str, *extra: str) -> tuple[str, ...]:
    return ("drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3", *extra)


@pytest.mark.parametrize("kind", sorted(CORRUPTIONS))
def test_a_scan_that_goes_bad_mid_run_ends_in_a_stop_and_one_line(capsys, serve, kind):
    bad = type("Bad", (BadScan,), {"corrupt": staticmethod(CORRUPTIONS[kind])})
    sim, address = serve(load_world("R1"), kind=bad, mode="lockstep")
    line = refused(capsys, *drive_args(address, *PATIENT))
    assert sim.bad_from == BAD_AFTER  # it drove before, then the scan went bad
    after = sim.received[sim.bad_from :]
    # a stop is the last command, and nothing but zero commands followed the first bad scan,
    # all within 0.5 s of robot time (lockstep: one control period of 0.1 s per command)
    assert sim.requests[-1][:2] == (0.0, 0.0)
    assert after and all(c == (0.0, 0.0) for c in after) and len(after) * 0.1 <= 0.5
    assert any(c != (0.0, 0.0) for c in sim.received[: sim.bad_from])
    if kind in BLIND:
        assert len(after) == BLIND_SCANS  # held still on the first two, stopped on the third
        assert f"blind for {BLIND_SCANS} scans in a row" in line
    else:
        assert len(after) == 1  # another layout: the stop at once
        assert "changed its layout mid-run" in line
    assert "the robot was stopped after" in line


def test_a_blind_scan_stops_within_half_a_second_of_wall_time(serve):
    """Realtime: the robot's own clock runs, the loop is paced; the stop comes within 0.5 s
    of the first bad scan, and nothing but zero commands after it."""
    sim, address = serve(load_world("R1"), kind=BadScan, mode="realtime")
    link = KachakaLink(address, timeout=0.5)
    pipeline = ReplayPipeline(make_controller("dwa3"))
    try:
        with pytest.raises(ScanError, match="blind"):
            drive(link, pipeline, DriveSettings((3.0, 0.0), watchdog_s=2.0))
    finally:
        link.close()
    assert sim.bad_since is not None
    after = [t for t in sim.times if t[0] >= sim.bad_since]
    assert after and all(t[1:] == (0.0, 0.0) for t in after)
    assert after[-1][0] - sim.bad_since <= 0.5
    assert sim.requests[-1][:2] == (0.0, 0.0)


class BadOdometry(SimulatedKachaka):
    """A robot whose odometry goes wrong (``corrupt``) from snapshot BAD_AFTER + 1 on."""

    corrupt = staticmethod(lambda msg: None)

    def GetRosOdometry(self, request, context):  # noqa: N802
        response = super().GetRosOdometry(request, context)
        if self.cursor > BAD_AFTER:
            self.bad_from = getattr(self, "bad_from", None) or len(self.received)
            self.corrupt(response.odometry)
        return response


def _nan_x(msg) -> None:
    msg.pose.pose.position.x = math.nan


def _teleport(msg) -> None:
    msg.pose.pose.position.y += 2.0


def _wild_twist(msg) -> None:
    msg.twist.twist.linear.x = 25.0


@pytest.mark.parametrize(
    ("corrupt", "says"),
    [
        (_nan_x, "non-finite odometry pose (nan,"),
        (_teleport, "odometry that jumped 2 m"),
        (_wild_twist, "odometry twist (25 m/s"),
    ],
    ids=["nan", "teleport", "twist"],
)
def test_odometry_that_stops_making_sense_ends_in_a_stop(capsys, serve, corrupt, says):
    bad = type("Bad", (BadOdometry,), {"corrupt": staticmethod(corrupt)})
    sim, address = serve(load_world("R1"), kind=bad, mode="lockstep")
    line = refused(capsys, *drive_args(address, *PATIENT))
    assert says in line and "the robot was stopped after" in line
    assert sim.bad_from == BAD_AFTER and sim.received[BAD_AFTER:] == [(0.0, 0.0)]
    assert sim.requests[-1][:2] == (0.0, 0.0)


# -- the checks on their own ---------------------------------------------------------------


def scan(ranges: np.ndarray, stamp: int = 1) -> LaserScan:
    return LaserScan(LIDAR.angle_min, LIDAR.increment, ranges, 0.05, 10.0, stamp)


def test_the_scan_contract_holds_a_blind_scan_and_ends_on_the_third_in_a_row():
    good = np.full(LIDAR.beams, 2.0)
    contract = ScanContract(scan(good), LIDAR.mount, ObservationParams())
    assert contract.check(scan(np.full(LIDAR.beams, np.inf))) is None  # free space reads
    assert contract.check(scan(np.full(LIDAR.beams, -np.inf))) is None  # so does "too close"
    assert MIN_READING_FRACTION == 0.5 and LIDAR.beams == 481
    few = good.copy()
    few[1::2] = 0.0  # every other beam: 241 of 481 read, just enough
    assert contract.check(scan(few)) is None
    few[0] = np.nan
    assert contract.check(scan(few)) == "240 of 481 beams read"
    assert contract.check(scan(good)) is None and contract.blind == 0  # a glitch, gone
    dark = good.copy()
    dark[:40] = np.nan  # the rightmost observation sector (beams 0-59) keeps 20 beams
    assert contract.check(scan(dark)) is None
    dark[:60] = np.nan
    assert contract.check(scan(dark)) == "no beam reads in sector(s) 0"
    assert contract.check(scan(dark)) is not None
    with pytest.raises(ScanError, match=r"blind for 3 scans in a row \(at stamp 7 ns"):
        contract.check(scan(dark, stamp=7))


def test_the_scan_contract_refuses_another_layout_at_once():
    contract = ScanContract(scan(np.full(LIDAR.beams, 2.0)), LIDAR.mount, ObservationParams())
    with pytest.raises(ScanError, match="beams 480, was 481"):
        contract.check(scan(np.full(LIDAR.beams - 1, 2.0)))
    narrower = LaserScan(LIDAR.angle_min / 2, LIDAR.increment / 2, np.full(LIDAR.beams, 2.0),
                         0.05, 10.0)  # fmt: skip
    with pytest.raises(ScanError, match="first angle -1.0472, was -2.0944"):
        contract.check(narrower)
    shorter = LaserScan(LIDAR.angle_min, LIDAR.increment, np.full(LIDAR.beams, 2.0), 0.05, 4.0)
    with pytest.raises(ScanError, match="range_max 4, was 10"):
        contract.check(shorter)


def _reading(pose, twist=(0.0, 0.0), stamp=1_000_000_000, imu=None) -> Reading:
    odom = Odometry(pose, twist, stamp)
    return Reading(scan(np.full(LIDAR.beams, 2.0), stamp), odom, odom, imu, stamp)


def test_the_odometry_check_bounds_jumps_by_the_time_between_stamps():
    check = OdometryCheck(0.4, 2.0)
    check.check(_reading((0.0, 0.0, 0.0)), "robot")
    check.check(_reading((0.55, 0.0, 0.5), stamp=1_100_000_000), "robot")  # 0.5 + 0.08 m
    with pytest.raises(RobotLinkError, match="jumped 0.6 m"):
        check.check(_reading((1.15, 0.0, 0.5), stamp=1_200_000_000), "robot")
    check = OdometryCheck(0.4, 2.0)
    check.check(_reading((0.0, 0.0, 3.1)), "robot")
    check.check(_reading((0.0, 0.0, -3.1), stamp=1_000_000_000), "robot")  # across +-pi
    with pytest.raises(RobotLinkError, match="non-finite gyro yaw rate"):
        check.check(_reading((0.0, 0.0, -3.1), imu=math.inf), "robot")
    with pytest.raises(RobotLinkError, match=r"twist \(0.1 m/s, -9 rad/s\) beyond 0.8 m/s"):
        check.check(_reading((0.0, 0.0, -3.1), twist=(0.1, -9.0)), "robot")


def test_a_healthy_run_is_not_held(serve):
    """The contract never holds the simulated robot: R1 reaches its goal as before."""
    sim, address = serve(load_world("R1"), mode="lockstep")
    link = KachakaLink(address, timeout=30)
    try:
        result = drive(
            link,
            ReplayPipeline(make_controller("dwa3")),
            DriveSettings((3.0, 0.0), lockstep=True, watchdog_s=60.0),
            result=DriveResult(),
        )
    finally:
        link.close()
    assert result.outcome == "goal" and result.stopped


def test_an_onnx_policy_that_returns_nan_stops_the_robot_with_one_line(capsys, serve, tmp_path):
    """A bad decision is a stop and one line, never action 0 (issue 31)."""
    file = tmp_path / "nan.onnx"
    file.write_bytes(nan_on_a_free_sector().SerializeToString())
    sim, address = serve(load_world("R1"), mode="lockstep")
    args = ("drive", "--kachaka", address, "--goal", "3,0", "--method", "d3dwa", "--onnx")
    line = refused(capsys, *args, file, *PATIENT)
    assert str(file) in line and "Q-values are NaN or inf" in line
    assert "the robot was stopped after 0 commands" in line
    assert sim.received == [] and sim.requests[-1][:2] == (0.0, 0.0)
