"""Kachaka's geometry: robot.py and urdf/kachaka.urdf state the same numbers."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from d3dwa_bullet import robot
from d3dwa_bullet.geometry import body_outline
from d3dwa_bullet.params import Footprint
from d3dwa_bullet.resources import urdf_path
from d3dwa_bullet.sim.lidar import LidarParams
from d3dwa_bullet.sim.odometry import WheelOdometry


@pytest.fixture(scope="module")
def urdf() -> ET.Element:
    return ET.parse(urdf_path()).getroot()


def numbers(text: str | None) -> tuple[float, ...]:
    return tuple(float(v) for v in (text or "").split())


def link(urdf: ET.Element, name: str) -> ET.Element:
    (found,) = [e for e in urdf.findall("link") if e.get("name") == name]
    return found


def joint_origin(urdf: ET.Element, name: str) -> tuple[float, ...]:
    (joint,) = [e for e in urdf.findall("joint") if e.get("name") == name]
    origin = joint.find("origin")
    assert origin is not None and numbers(origin.get("rpy")) == (0.0, 0.0, 0.0)
    return numbers(origin.get("xyz"))


def test_body_box_is_robots(urdf):
    base = link(urdf, "base_link")
    for part in ("collision", "visual"):
        elem = base.find(part)
        assert elem is not None
        assert numbers(elem.find("geometry/box").get("size")) == robot.BODY_SIZE
        assert numbers(elem.find("origin").get("xyz")) == robot.BODY_CENTER
    assert numbers(base.find("inertial/origin").get("xyz")) == robot.BODY_CENTER
    assert (robot.BODY_HALF_LENGTH, robot.BODY_HALF_WIDTH) == (0.1935, 0.120)


@pytest.mark.parametrize(("side", "sign"), [("left", 1.0), ("right", -1.0)])
def test_wheels_are_robots(urdf, side, sign):
    cylinder = link(urdf, f"{side}_wheel_link").find("collision/geometry/cylinder")
    assert cylinder is not None
    assert float(cylinder.get("radius")) == robot.WHEEL_RADIUS
    assert float(cylinder.get("length")) == robot.WHEEL_WIDTH
    assert joint_origin(urdf, f"{side}_wheel_joint") == (0.0, sign * robot.TRACK / 2, 0.0)


def test_sensor_mounts_are_robots(urdf):
    assert joint_origin(urdf, "lidar_link_joint") == robot.LIDAR_MOUNT
    assert joint_origin(urdf, "imu_link_joint") == robot.IMU_MOUNT


def test_defaults_elsewhere_are_robots():
    lidar = LidarParams()
    assert (lidar.mount_x, lidar.mount_y, lidar.mount_z) == robot.LIDAR_MOUNT
    odo = WheelOdometry()
    assert (odo.radius_left, odo.radius_right, odo.track) == (
        robot.WHEEL_RADIUS,
        robot.WHEEL_RADIUS,
        robot.TRACK,
    )
    fp = Footprint()
    assert (fp.radius, fp.centers_x) == (robot.FOOTPRINT_RADIUS, robot.FOOTPRINT_CENTERS_X)


def test_footprint_circles_cover_the_body_box():
    outline = body_outline((0.0, 0.0, 0.0), samples_per_side=64)
    centers = np.column_stack((robot.FOOTPRINT_CENTERS_X, np.zeros(3)))
    nearest = np.min(np.hypot(*(outline[:, None, :] - centers[None]).transpose(2, 0, 1)), axis=1)
    assert nearest.max() < robot.FOOTPRINT_RADIUS
