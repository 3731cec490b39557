"""Kachaka API messages carry scans, odometry and commands bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.live.messages import (  # noqa: E402
    command_metadata,
    command_of,
    encode_fraction,
    imu_message,
    odometry_from_message,
    odometry_message,
    scan_from_message,
    scan_message,
    velocity_of,
    velocity_request,
)
from d3dwa_bullet.sim.scan import LaserScan  # noqa: E402


def test_scan_round_trip_is_exact():
    rng = np.random.default_rng(3)
    ranges = rng.uniform(0.05, 10.0, 481).astype(np.float32).astype(np.float64)
    ranges[[3, 7, 11]] = [np.inf, np.nan, 0.0]
    scan = LaserScan(
        float(np.float32(-2.0943951)), float(np.float32(0.00872665)), ranges, 0.05, 10.0, 1234
    )
    back = scan_from_message(scan_message(scan))
    assert back.stamp_ns == 1234
    assert (back.angle_min, back.angle_increment) == (scan.angle_min, scan.angle_increment)
    np.testing.assert_array_equal(back.ranges, scan.ranges)  # NaN == NaN here
    assert scan_message(scan).angle_max == pytest.approx(-scan.angle_min, abs=1e-5)


@pytest.mark.parametrize("yaw", [0.0, 0.1, -1.0, 3.0, -3.1, math.pi])
def test_odometry_round_trip_is_exact(yaw):
    pose, twist = (1.25, -0.3, yaw), (0.123456789, -1.5)
    odom = odometry_from_message(odometry_message(pose, twist, 99))
    assert odom.pose[:2] == pose[:2] and odom.twist == twist and odom.stamp_ns == 99
    assert odom.pose[2] == (yaw if yaw != -math.pi else math.pi)


def test_imu_carries_the_yaw_rate():
    msg = imu_message(-0.75, 5)
    assert msg.angular_velocity.z == -0.75 and msg.header.stamp_nsec == 5


def test_fraction_is_exact_where_one_exists():
    rng = np.random.default_rng(0)
    values = rng.uniform(-0.4, 0.4, 2000)
    exact = sum(encode_fraction(v, 0.3) * 0.3 == v for v in values)
    plain = sum((v / 0.3) * 0.3 == v for v in values)
    assert exact >= plain and exact > 0.75 * len(values)
    assert all(abs(encode_fraction(v, 0.3) * 0.3 - v) < 1e-16 for v in values)


def test_exact_command_travels_as_metadata():
    rng = np.random.default_rng(1)
    for v, w in rng.uniform(-1.0, 1.0, (200, 2)):
        request = velocity_request(v, w)
        assert command_of(request, command_metadata(v, w)) == (v, w)
        assert command_of(request, ()) == velocity_of(request)


def test_metadata_that_disagrees_with_the_fractions_is_ignored():
    request = velocity_request(0.2, 0.5)
    assert command_of(request, command_metadata(0.25, 0.5)) == velocity_of(request)
    assert command_of(request, (("d3dwa-command", "not numbers"),)) == velocity_of(request)
