"""``calibrate_scans`` recovers known lidar errors from synthetic bags (within 20 %): range noise,
dropout per sector and its NaN / +inf / -inf / 0.0 / out-of-range mix, phantom returns, beam
count, field of view and scan rate; also a 360 deg 5 Hz scanner on other topics without IMU,
a robot that never stands still (line-fit fallback) and one without odometry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.errors import BagFormatError
from transfer.bag_reader import read_bag
from transfer.calibrate_scans import MIN_SCANS, calibrate_scans
from transfer.calibrate_synthetic import (
    SyntheticLidar,
    SyntheticRun,
    write_calibration_bag,
)
from transfer.compare import READING_CLASSES
from transfer.topics import TopicMap

LIDAR = SyntheticLidar()
TOL = 0.2
RUN = SyntheticRun()
#: Only a scan topic, under another name: no odometry, no IMU.
SCAN_ONLY = TopicMap(
    scan="/front/scan", odometry=None, wheel_odometry=None, imu=None, tf=None, goal=None,
    cmd_vel=None, planner_params=None,
)  # fmt: skip


def fit(path: Path, lidar: SyntheticLidar = LIDAR, run: SyntheticRun = RUN):
    write_calibration_bag(path, lidar=lidar, run=run)
    return calibrate_scans([read_bag(path)])


@pytest.fixture(scope="module")
def kachaka(tmp_path_factory: pytest.TempPathFactory):
    return fit(tmp_path_factory.mktemp("cal") / "bag")


@pytest.mark.parametrize(
    "name, truth",
    [
        ("lidar.range_std", LIDAR.range_std),
        ("lidar.spurious_prob", LIDAR.spurious_prob),
        ("lidar.spurious_min", LIDAR.spurious_min),
        ("lidar.spurious_max", LIDAR.spurious_max),
        ("lidar.dropout_prob", float(np.mean(LIDAR.dropout))),
    ],
)
def test_scalar_lidar_parameters_are_recovered(kachaka, name: str, truth: float) -> None:
    assert kachaka.estimates[name].value == pytest.approx(truth, rel=TOL)
    assert kachaka.estimates[name].how


def test_range_noise_comes_from_stationary_scans(kachaka) -> None:
    assert kachaka.estimates["lidar.range_std"].how.startswith("stationary-scan differences")
    assert kachaka.notes == []


@pytest.mark.parametrize("sector", range(8))
def test_dropout_rate_per_sector(kachaka, sector: int) -> None:
    est = kachaka.estimates
    rate = est["lidar.dropout_prob"].value * est["lidar.dropout_sector_scale"].value[sector]
    assert rate == pytest.approx(LIDAR.dropout[sector], rel=TOL)
    assert kachaka.sectors[sector]["rate"] == pytest.approx(rate, rel=1e-3)


@pytest.mark.parametrize("kind", range(5))
def test_dropout_kind_mix(kachaka, kind: int) -> None:
    counts = np.array([[s[c] for c in READING_CLASSES] for s in kachaka.sectors]).sum(axis=0)
    assert counts[kind] / counts.sum() == pytest.approx(LIDAR.kinds[kind], rel=TOL)
    rows = np.array(kachaka.estimates["lidar.dropout_sector_kinds"].value)
    assert rows.shape == (8, 5) and np.allclose(rows.sum(axis=1), 1.0)
    # the two sectors with the most dropouts (10 %) have their own mix, within 20 % too
    assert rows[:2, kind] == pytest.approx([LIDAR.kinds[kind]] * 2, rel=TOL)


def test_sensor_geometry_and_rate(kachaka) -> None:
    s = kachaka.sensor
    assert (s["beams"], s["fov_deg"], s["scan_rate_hz"]) == (481, 240.0, 10.0)


def test_360_degree_5_hz_scanner_on_other_topics(tmp_path: Path) -> None:
    lidar = SyntheticLidar(
        beams=360, fov_deg=359.0, rate_hz=5.0, range_std=0.01, dropout=(0.03,) * 8,
        kinds=(0.0, 1.0, 0.0, 0.0, 0.0), spurious_prob=0.0,
    )  # fmt: skip
    topics = TopicMap(scan="/base_scan", odometry="/odom", wheel_odometry=None, imu=None)
    cal = fit(tmp_path / "b", lidar, SyntheticRun(still_s=4.0, topics=topics, seed=2))
    s = cal.sensor
    assert (s["beams"], s["fov_deg"], s["scan_rate_hz"]) == (360, 359.0, 5.0)
    assert cal.estimates["lidar.range_std"].value == pytest.approx(0.01, rel=TOL)
    assert "/odom" in cal.estimates["lidar.range_std"].how
    assert cal.estimates["lidar.dropout_prob"].value == pytest.approx(0.03, rel=TOL)
    assert cal.estimates["lidar.spurious_prob"].value < 1e-3


def test_never_standing_still_falls_back_to_line_fits(tmp_path: Path) -> None:
    topics = TopicMap(scan="/front/scan", odometry="/odom", wheel_odometry=None, imu=None)
    cal = fit(tmp_path / "b", run=SyntheticRun(still_s=0.0, drive_s=6.0, topics=topics))
    est = cal.estimates["lidar.range_std"]
    assert est.value == pytest.approx(LIDAR.range_std, rel=TOL)
    assert est.how.startswith("line-fit residuals")
    assert len(cal.notes) == 1 and "never stands still" in cal.notes[0]


def test_stillness_from_scan_change_without_odometry(tmp_path: Path) -> None:
    cal = fit(tmp_path / "b", run=SyntheticRun(still_s=2.0, drive_s=4.0, topics=SCAN_ONLY))
    est = cal.estimates["lidar.range_std"]
    assert "scan-to-scan change" in est.how
    assert est.value == pytest.approx(LIDAR.range_std, rel=TOL)
    pairs = int(est.how.split(" over ")[1].split()[0])
    assert 15 <= pairs <= 21  # 2 s standing at 10 Hz: about 19 still pairs, none while driving


def test_too_few_scans_says_how_many_are_needed(tmp_path: Path) -> None:
    run = SyntheticRun(still_s=0.5, drive_s=0.4)
    with pytest.raises(BagFormatError, match=f"at least {MIN_SCANS} scans"):
        fit(tmp_path / "b", run=run)


def test_noise_free_scans_give_zero_noise_and_no_dropout(tmp_path: Path) -> None:
    lidar = SyntheticLidar(range_std=0.0, dropout=(0.0,) * 8, spurious_prob=0.0)
    cal = fit(tmp_path / "b", lidar, SyntheticRun(drive_s=3.0))
    assert cal.estimates["lidar.range_std"].value < 1e-4
    assert cal.estimates["lidar.dropout_prob"].value == 0.0
    assert "lidar.dropout_sector_scale" not in cal.estimates
    assert cal.estimates["lidar.spurious_prob"].value == 0.0
    assert math.isfinite(cal.sensor["scan_rate_hz"])
