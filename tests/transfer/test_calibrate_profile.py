"""The calibrated profile file: loads with ``load_profile`` (so ``--noise`` and a training
config's ``noise:`` list take it), holds the estimates, comments every parameter, keeps the
base's values where the bags say nothing, and its per-sector tables change the simulation."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from d3dwa_bullet.learning.tasks import TaskSampler
from d3dwa_bullet.sim.noise import NoiseModel
from randomization.profiles import load_profile
from transfer.calibrate_synthetic import SyntheticRun, write_calibration_bag
from transfer.calibration import calibrate
from transfer.topics import TopicMap


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory):
    tmp = tmp_path_factory.mktemp("profile")
    write_calibration_bag(tmp / "bag", run=SyntheticRun(drive_s=20.0))
    result = calibrate([tmp / "bag"], tmp / "my_robot.yaml", base="real")
    return result, tmp / "my_robot.yaml"


def test_profile_round_trips_and_holds_the_estimates(calibrated) -> None:
    result, path = calibrated
    profile = load_profile(path)
    assert profile.name == "my_robot"
    config = profile.sample(np.random.default_rng(0))
    scans = result.scan_fit.estimates
    assert config.lidar.range_std == scans["lidar.range_std"].value
    assert config.lidar.dropout_sector_scale == tuple(scans["lidar.dropout_sector_scale"].value)
    assert (
        config.odometry.track_error_std
        == result.motion_fit.estimates["odometry.track_error_std"].value
    )


def test_every_parameter_says_how_it_was_estimated_or_why_kept(calibrated) -> None:
    result, path = calibrated
    text = path.read_text()
    params = text.split("\nparams:\n")[1]
    for line in params.splitlines():
        if re.match(r"^    \w+:", line):
            assert re.search(r"# (estimated: .+|kept from base 'real': .+)", line), line
    assert "sensor:  # informational" in text
    data = yaml.safe_load(text)
    assert data["sensor"]["beams"] == 481 and data["sensor"]["scan_rate_hz"] == 10.0
    names = set(result.estimated) | set(result.kept_from_base)
    assert {"lidar.range_std", "imu.gyro_std", "sensor.fov_deg"} <= set(result.estimated)
    assert {"slip.level_mean", "latency.steps", "imu.bias_walk_std"} <= set(result.kept_from_base)
    assert len(names) == len(result.estimated) + len(result.kept_from_base)


def test_kept_values_are_the_bases(tmp_path: Path) -> None:
    topics = TopicMap(wheel_odometry=None, imu=None)
    write_calibration_bag(tmp_path / "bag", run=SyntheticRun(drive_s=4.0, topics=topics))
    calibrate([tmp_path / "bag"], tmp_path / "h.yaml", base="harsh")
    mine = yaml.safe_load((tmp_path / "h.yaml").read_text())["params"]
    harsh = yaml.safe_load(Path(load_profile("harsh").source).read_text())["params"]
    for group in ("slip", "odometry", "imu", "latency", "physics", "pose_fix"):
        assert mine[group] == harsh[group]
    assert "kept from base 'harsh': no IMU in the bags" in (tmp_path / "h.yaml").read_text()


def test_training_config_noise_list_takes_the_file(calibrated) -> None:
    _, path = calibrated
    sampler = TaskSampler(worlds=("TS1",), noise=("none", str(path)))
    model = sampler.noise(str(path), seed=3)
    assert isinstance(model, NoiseModel)
    assert model.config.lidar.dropout_sector_kinds is not None


def test_calibrated_dropout_tables_change_the_simulated_scan(calibrated) -> None:
    _, path = calibrated
    config = load_profile(path).sample(np.random.default_rng(0))
    plain = config.lidar.__class__(
        **{**vars(config.lidar), "dropout_sector_scale": None, "dropout_sector_kinds": None}
    )
    ranges = np.full(481, 2.0)
    a = NoiseModel(config, seed=1).corrupt_ranges(ranges, 0.05, 10.0)
    b = NoiseModel(config.__class__(lidar=plain), seed=1).corrupt_ranges(ranges, 0.05, 10.0)
    assert np.isneginf(a).any() and not np.isneginf(b).any()
