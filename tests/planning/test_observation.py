"""Observation (docs/design/observation.md#observation) and the LaserScan record's REP-117 handling."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ScanError
from d3dwa_bullet.planning.observation import build_observation, goal_in_body, sector_ranges
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body


def test_layout_and_normalisation():
    obs = build_observation((0, 0, 0), (0.2, -1.0), (3.0, 3.0), np.zeros((0, 2)))
    assert obs.shape == (12,)
    assert obs[0] == pytest.approx(math.hypot(3, 3) / 6.0)
    assert obs[1] == pytest.approx(0.25)  # 45 deg left / 180 deg
    assert obs[2:4] == pytest.approx([0.5, -0.5])
    assert obs[4:] == pytest.approx(1.0)  # empty sectors read 1.0


def test_goal_distance_is_clipped_and_bearing_is_body_frame():
    obs = build_observation((1.0, 1.0, math.pi / 2), (0, 0), (1.0, 20.0), np.zeros((0, 2)))
    assert obs[0] == 1.0 and obs[1] == pytest.approx(0.0)
    assert goal_in_body((1.0, 1.0, math.pi / 2), (0.0, 1.0)) == pytest.approx([0.0, 1.0])


def test_sectors_take_the_minimum_range_right_to_left():
    def at(deg, r):
        return [r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg))]

    pts = np.array([at(1, 1.0), at(2, 2.0), at(-75, 1.5), at(100, 0.7), at(135, 0.2), at(180, 0.1)])
    s = sector_ranges(pts)
    assert s[4] == pytest.approx(1.0)  # 0..30 deg: sector 4, the nearer of two points
    assert s[1] == pytest.approx(1.5)  # -90..-60 deg: sector 1
    assert s[7] == pytest.approx(0.7)  # 90..120 deg: sector 7; 135 and 180 deg lie outside
    assert np.isinf(s[[0, 2, 3, 5, 6]]).all()
    obs = build_observation((0, 0, 0), (0, 0), (1, 0), pts)
    assert obs[4 + 4] == pytest.approx(1.0 / 3.5)
    assert obs[4 + 7] == pytest.approx(0.2)
    assert obs[4 + 0] == 1.0


def make_scan(ranges, rmin=0.05, rmax=10.0):
    return LaserScan(-math.pi / 2, math.pi / 2, np.asarray(ranges, float), rmin, rmax)


def test_rep117_invalid_readings_are_never_obstacles():
    scan = make_scan([np.nan, np.inf, 0.0, -np.inf, 20.0, 0.01, 1.0])
    valid = scan.valid_mask()
    assert valid.tolist() == [False] * 6 + [True]
    pts = scan_points_body(LaserScan(0.0, 0.1, scan.ranges, 0.05, 10.0), Pose2D(0.156, 0, 0))
    assert len(pts) == 1 and np.isfinite(pts).all()


def test_points_use_the_mounting_pose():
    scan = LaserScan(0.0, 0.1, np.array([1.0]), 0.05, 10.0)
    pts = scan_points_body(scan, Pose2D(0.2, 0.1, math.pi / 2))
    assert pts == pytest.approx(np.array([[0.2, 1.1]]))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(ranges=np.array([])), "ranges"),
        (dict(angle_increment=0.0), "angle_increment"),
        (dict(angle_min=np.nan), "angle_min"),
        (dict(range_min=5.0, range_max=1.0), "range_min"),
    ],
)
def test_malformed_scans_raise_scan_error(kwargs, field):
    base = dict(
        angle_min=0.0, angle_increment=0.1, ranges=np.ones(3), range_min=0.05, range_max=10.0
    )
    with pytest.raises(ScanError, match=field):
        LaserScan(**(base | kwargs))


def test_nan_points_raise_a_scan_error_naming_the_index():
    with pytest.raises(ScanError, match=r"points\[1\]"):
        sector_ranges(np.array([[1.0, 0.0], [np.nan, 0.0]]))
