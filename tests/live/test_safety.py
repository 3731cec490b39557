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
