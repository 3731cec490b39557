"""``calibrate_motion`` recovers known odometry and gyro errors (within 20 %) where the bag has
wheel odometry, a reference odometry and an IMU, and keeps the base's values, saying why,
where it has not."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from transfer.bag_reader import read_bag
from transfer.calibrate_motion import IMU_PARAMS, ODOMETRY_PARAMS, calibrate_motion
from transfer.calibrate_synthetic import SyntheticMotion, SyntheticRun, write_calibration_bag
from transfer.topics import TopicMap

MOTION = SyntheticMotion()
TOL = 0.2
RADIUS_RMS = math.sqrt(0.5 * sum((s - 1.0) ** 2 for s in MOTION.radius_scale))


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory):
    path = tmp_path_factory.mktemp("motion") / "bag"
    write_calibration_bag(path, motion=MOTION, run=SyntheticRun(seed=1))
    return calibrate_motion([read_bag(path)])


@pytest.mark.parametrize(
    "name, truth",
    [
        ("odometry.radius_error_std", RADIUS_RMS),
        ("odometry.track_error_std", MOTION.track_scale - 1.0),
        ("odometry.walk_std", MOTION.walk_std),
        ("odometry.yaw_walk_std", MOTION.yaw_walk_std),
        ("imu.gyro_std", MOTION.gyro_std),
        ("imu.bias_std", MOTION.gyro_bias),
    ],
)
def test_odometry_and_gyro_parameters_are_recovered(fitted, name: str, truth: float) -> None:
    assert fitted.estimates[name].value == pytest.approx(truth, rel=TOL)


def test_each_scale_and_the_bias_sign(fitted) -> None:
    fit = fitted.fit
    assert fit["scale_left"] - 1 == pytest.approx(MOTION.radius_scale[0] - 1, rel=0.3)
    assert fit["scale_right"] - 1 == pytest.approx(MOTION.radius_scale[1] - 1, rel=0.3)
    assert fit["bias"] > 0


def test_constant_bias_has_no_identifiable_wander(fitted) -> None:
    assert "imu.bias_walk_std" not in fitted.estimates
    assert "not identifiable" in fitted.kept["imu.bias_walk_std"]


def test_without_imu_or_wheel_odometry_everything_is_kept(tmp_path: Path) -> None:
    topics = TopicMap(odometry="/odom", wheel_odometry=None, imu=None)
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(drive_s=5.0, topics=topics))
    cal = calibrate_motion([read_bag(tmp_path / "b")])
    assert cal.estimates == {}
    assert set(cal.kept) == set(ODOMETRY_PARAMS) | set(IMU_PARAMS)
    assert cal.kept["imu.gyro_std"] == "no IMU in the bags"
    assert cal.kept["odometry.walk_std"] == "no wheel odometry in the bags"


def test_without_reference_nothing_is_compared(tmp_path: Path) -> None:
    topics = TopicMap(odometry=None)
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(drive_s=5.0, topics=topics))
    cal = calibrate_motion([read_bag(tmp_path / "b")])
    assert cal.estimates == {}
    assert all("reference" in why for why in cal.kept.values())


def test_too_little_motion_is_named(tmp_path: Path) -> None:
    write_calibration_bag(tmp_path / "b", run=SyntheticRun(still_s=2.0, drive_s=2.0))
    cal = calibrate_motion([read_bag(tmp_path / "b")])
    assert "need 1.0 m" in cal.kept["odometry.radius_error_std"]
    assert "imu.gyro_std" in cal.estimates  # the gyro needs no travel
