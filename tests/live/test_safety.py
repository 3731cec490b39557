"""The clamp, the staleness check and the watchdog."""

from __future__ import annotations

import math
import threading
import time

import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.errors import ConfigError, RobotLinkError  # noqa: E402
from d3dwa_bullet.live.safety import Freshness, SpeedLimits, Watchdog  # noqa: E402

MS = 1_000_000


@pytest.mark.parametrize(
    ("command", "expected"),
    [
        ((0.2, 1.0), (0.2, 1.0)),
        ((0.4, 2.0), (0.3, 1.57)),
        ((-0.5, -3.0), (-0.3, -1.57)),
        ((math.nan, math.inf), (0.0, 0.0)),
    ],
)
def test_commands_are_clamped_to_the_kachaka_limits(command, expected):
    assert SpeedLimits().clamp(*command) == expected


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan])
def test_speed_limits_must_be_positive(bad):
    with pytest.raises(ConfigError):
        SpeedLimits(v_max=bad)


def test_a_stamp_that_stops_advancing_turns_stale():
    fresh = Freshness(0.2)
    fresh.check({"scan": 100 * MS, "odometry": 100 * MS}, now=0.0, where="robot")
    fresh.check({"scan": 100 * MS, "odometry": 100 * MS}, now=0.15, where="robot")
    fresh.check({"scan": 200 * MS, "odometry": 200 * MS}, now=0.30, where="robot")
    with pytest.raises(RobotLinkError, match="stale scan: its stamp has not changed for 0.25 s"):
        fresh.check({"scan": 200 * MS, "odometry": 300 * MS}, now=0.55, where="robot")


def test_in_realtime_a_frozen_stamp_is_judged_by_the_wall_not_by_how_often_it_is_read():
    """A realtime loop may read one snapshot many times within a period: only the injected
    wall clock decides."""
    fresh = Freshness(0.2)
    for k in range(100):  # a hundred reads within 0.19 s of wall: fresh
        fresh.check({"scan": 100 * MS, "odometry": 100 * MS}, now=k * 0.0019, where="robot")
    with pytest.raises(RobotLinkError, match="stale scan: its stamp has not changed for 0.21 s"):
        fresh.check({"scan": 100 * MS, "odometry": 100 * MS}, now=0.21, where="robot")


@pytest.mark.parametrize("stale_s", [None, 0.25])
def test_in_lockstep_a_frozen_stamp_is_judged_by_control_periods_not_by_the_wall(stale_s):
    """Lockstep: ``now`` counts the commands sent, each advancing the robot one period; a
    stamp unchanged over more than stale_s / period of them (2 by default) is stale, at the
    third, however little wall time passed (issue 58, class 4)."""
    period = 0.1
    fresh = Freshness(stale_s or 2 * period, period_s=period)
    for step in range(4):  # stamps advance with the commands
        fresh.check({"scan": step * 100 * MS, "odometry": step * 100 * MS}, step, "robot")
    frozen = {"scan": 300 * MS, "odometry": 300 * MS}
    for step in (4, 5):  # one and two periods without a change: within the limit
        fresh.check(frozen, step, "robot")
    with pytest.raises(
        RobotLinkError, match=r"stale scan: its stamp has not changed over 3 control periods"
    ):
        fresh.check(frozen, 6, "robot")


def test_in_lockstep_the_stream_that_stops_is_named():
    fresh = Freshness(0.2, period_s=0.1)
    for step in range(3):
        fresh.check({"scan": 0, "odometry": step * 100 * MS}, step, "robot")
    with pytest.raises(RobotLinkError, match="stale scan"):  # the lag on the robot's clock
        fresh.check({"scan": 0, "odometry": 300 * MS}, 3, "robot")
    fresh = Freshness(0.2, period_s=0.1)
    for step in range(3):
        fresh.check({"odometry": 500 * MS}, step, "robot")  # a single stream: no lag to see
    with pytest.raises(RobotLinkError, match="stale odometry: .* over 3 control periods"):
        fresh.check({"odometry": 500 * MS}, 3, "robot")


@pytest.mark.parametrize("period", [0.0, -0.1, math.nan])
def test_a_lockstep_period_must_be_positive(period):
    with pytest.raises(ConfigError, match="control period"):
        Freshness(0.2, period_s=period)


def test_a_stream_lagging_the_scan_is_stale():
    fresh = Freshness(0.2)
    fresh.check({"scan": 500 * MS, "odometry": 400 * MS}, now=0.0, where="robot")
    with pytest.raises(RobotLinkError, match=r"stale odometry: 0.30 s older than the scan"):
        fresh.check({"scan": 800 * MS, "odometry": 500 * MS}, now=0.1, where="robot")


def test_a_scan_lagging_the_odometry_is_stale():
    fresh = Freshness(0.2)
    with pytest.raises(RobotLinkError, match=r"stale scan: 0.25 s older than the odometry"):
        fresh.check({"scan": 500 * MS, "odometry": 750 * MS}, now=0.0, where="robot")


def test_a_stamp_going_back_is_refused():
    fresh = Freshness(0.2)
    fresh.check({"scan": 500 * MS}, now=0.0, where="robot")
    with pytest.raises(RobotLinkError, match="back in time"):
        fresh.check({"scan": 400 * MS}, now=0.05, where="robot")


def test_watchdog_stops_a_stalled_loop_and_refuses_commands_after():
    stopped = threading.Event()
    sent = []
    dog = Watchdog(0.05, stopped.set).start()
    dog.send(sent.append, "before")
    assert stopped.wait(5.0)  # no beat: it fires
    with pytest.raises(RobotLinkError, match="watchdog stopped the robot"):
        dog.send(sent.append, "after")
    dog.close()
    assert sent == ["before"] and dog.fired


def test_watchdog_stays_quiet_while_the_loop_beats():
    stopped = threading.Event()
    dog = Watchdog(2.0, stopped.set).start()
    for _ in range(20):
        dog.beat()
        time.sleep(0.01)
    dog.close()
    assert not stopped.is_set() and not dog.fired
