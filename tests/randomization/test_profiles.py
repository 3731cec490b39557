"""Randomisation profiles: shipped ones load and sample deterministically; bad files are named."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ProfileError
from d3dwa_bullet.resources import profiles_dir
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.noise_config import NoiseConfig
from randomization import episode_noise, list_profiles, load_profile

SHIPPED = ["harsh", "none", "paper", "real", "wide", "wide-dynamics", "wide-lidar"]


def real_dict() -> dict[str, Any]:
    return yaml.safe_load((profiles_dir() / "real.yaml").read_text())


def write(tmp_path: Path, data: Any, name: str = "custom.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return path


def test_list_profiles() -> None:
    assert list_profiles() == SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_profiles_load_and_sample(name: str) -> None:
    profile = load_profile(name)
    assert profile.name == name and profile.version == 1 and profile.description
    a = [profile.sample(np.random.default_rng(3)).to_dict() for _ in range(2)]
    assert a[0] == a[1]
    config = profile.sample(np.random.default_rng(3))
    assert isinstance(config, NoiseConfig)
    assert config.enabled == (name != "none")


def test_none_profile_is_the_default_config() -> None:
    assert load_profile("none").sample(np.random.default_rng(0)) == NoiseConfig()


@pytest.mark.parametrize("name", ["real", "harsh"])
def test_random_profiles_differ_between_seeds(name: str) -> None:
    profile = load_profile(name)
    assert profile.sample(np.random.default_rng(1)) != profile.sample(np.random.default_rng(2))


def test_real_samples_stay_in_declared_ranges() -> None:
    profile, rng = load_profile("real"), np.random.default_rng(0)
    for _ in range(200):
        c = profile.sample(rng)
        assert 0.005 <= c.lidar.range_std <= 0.015
        assert 0.01 <= c.lidar.dropout_prob <= 0.03
        assert 0.01 <= c.slip.level_mean <= 0.03
        assert c.latency.steps in (0, 1)
        assert 1.0 <= c.pose_fix.rate_hz <= 2.0


@pytest.mark.parametrize("name", ["none", "paper", "real", "harsh"])
def test_harsh_is_worse_than_real_which_is_worse_than_none(name: str) -> None:
    rank = {"none": 0, "paper": 1, "real": 2, "harsh": 3}[name]
    c = load_profile(name).sample(np.random.default_rng(0))
    assert (c.lidar.dropout_prob > 0) == (rank >= 2)
    assert (c.slip.level_mean > 0.03) == (rank == 3)


def test_episode_noise_is_deterministic() -> None:
    profile = load_profile("real")
    a, b, c = episode_noise(profile, 5), episode_noise(profile, 5), episode_noise(profile, 6)
    assert a.config == b.config and a.physics == b.physics
    assert np.array_equal(a.slip_level, b.slip_level) and a.gyro_bias == b.gyro_bias
    assert (a.config, a.physics) != (c.config, c.physics)
    assert isinstance(a, NoiseModel)


def test_load_by_path_and_fixed_round_trip(tmp_path: Path) -> None:
    config = load_profile("harsh").sample(np.random.default_rng(9))
    data = {
        "name": "frozen",
        "version": 1,
        "description": "one harsh draw",
        "params": config.to_dict(),
    }
    profile = load_profile(write(tmp_path, data))
    assert profile.name == "frozen"
    assert profile.sample(np.random.default_rng(0)) == config
    assert load_profile(str(tmp_path / "custom.yaml")).sample(np.random.default_rng(1)) == config


def test_unknown_profile_lists_known() -> None:
    with pytest.raises(ProfileError, match="'realistic'.*harsh, none, paper, real"):
        load_profile("realistic")


def test_missing_file() -> None:
    with pytest.raises(ProfileError, match="no such profile file"):
        load_profile("does/not/exist.yaml")


def test_invalid_yaml(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match="not valid YAML"):
        load_profile(write(tmp_path, "params: [unclosed"))


def _set(path: str, value: Any):
    def edit(d: dict[str, Any]) -> None:
        *head, last = path.split(".")
        for key in head:
            d = d[key]
        d[last] = value

    return edit


def _delete(path: str):
    def edit(d: dict[str, Any]) -> None:
        *head, last = path.split(".")
        for key in head:
            d = d[key]
        del d[last]

    return edit


@pytest.mark.parametrize(
    ("edit", "needles"),
    [
        (_set("params.imu.gyro_std", -0.01), ["params.imu.gyro_std", "-0.01"]),
        (_set("params.slip.step_std", {"normal": [0.01, -0.1]}), ["params.slip.step_std", "-0.1"]),
        (_set("params.lidar.dropout_prob", 1.5), ["params.lidar.dropout_prob", "1.5"]),
        (
            _set("params.lidar.dropout_prob", {"uniform": [0.5, 1.2]}),
            ["params.lidar.dropout_prob", "1.2"],
        ),
        (
            _set("params.lidar.dropout_prob", {"uniform": [0.3, 0.1]}),
            ["params.lidar.dropout_prob", "lo <= hi"],
        ),
        (
            _set("params.pose_fix.dropout_prob", {"choice": [0.1, 7]}),
            ["params.pose_fix.dropout_prob", "7"],
        ),
        (
            _set("params.lidar.dropout_kinds", [0.5, 0.5, 0.5]),
            ["params.lidar.dropout_kinds", "0.5"],
        ),
        (_set("params.lidar.spurious_min", 2.0), ["spurious_min", "2.0"]),
        (_set("params.latency.steps", {"uniform": [0, 2]}), ["params.latency.steps", "uniform"]),
        (_set("params.latency.steps", 1.5), ["params.latency.steps", "1.5"]),
        (
            _set("params.latency.steps", {"choice": [0, 1], "weights": [1]}),
            ["params.latency.steps", "weights"],
        ),
        (
            _set("params.physics.mass_scale_range", [1.2, 0.8]),
            ["params.physics.mass_scale_range", "1.2"],
        ),
        (
            _set("params.physics.mass_scale_range", {"uniform": [0.8, 1.2]}),
            ["mass_scale_range", "uniform"],
        ),
        (
            _set("params.imu.gyro_std", {"gaussian": [0.0, 1.0]}),
            ["params.imu.gyro_std", "gaussian"],
        ),
        (_set("params.imu.gyro_std", "small"), ["params.imu.gyro_std", "small"]),
        (_set("params.imu.gyro_stdev", 0.01), ["params.imu.gyro_stdev"]),
        (_set("params.wheels", {}), ["wheels"]),
        (_set("extra", 1), ["extra"]),
        (_delete("params.imu.bias_std"), ["params.imu.bias_std", "missing"]),
        (_delete("params.pose_fix"), ["params.pose_fix", "missing"]),
        (_delete("version"), ["version", "missing"]),
        (_set("version", 2), ["version", "2"]),
        (_set("version", "1"), ["version", "'1'"]),
    ],
)
def test_bad_profile_names_file_parameter_and_value(
    tmp_path: Path, edit, needles: list[str]
) -> None:
    data = copy.deepcopy(real_dict())
    edit(data)
    path = write(tmp_path, data, "bad_profile.yaml")
    with pytest.raises(ProfileError) as info:
        load_profile(path)
    message = str(info.value)
    assert "bad_profile.yaml" in message
    for needle in needles:
        assert needle in message, (needle, message)


def test_sample_needs_a_generator() -> None:
    with pytest.raises(ProfileError, match="Generator"):
        load_profile("real").sample(np.random.RandomState(0))  # type: ignore[arg-type]


def test_wide_spans_none_to_the_top_of_harsh() -> None:
    """`wide` (the d3dwa-dr recipe's training range) reaches from off to harsh's extremes."""
    rng = np.random.default_rng(0)
    wide = [load_profile("wide").sample(rng) for _ in range(400)]
    harsh = [load_profile("harsh").sample(rng) for _ in range(400)]
    for field in ("range_std", "dropout_prob", "spurious_prob"):
        w = [getattr(c.lidar, field) for c in wide]
        h = [getattr(c.lidar, field) for c in harsh]
        assert min(w) < 0.05 * max(h), field  # near off
        assert max(w) > 0.9 * max(h), field  # up to the top of harsh
    assert {c.latency.steps for c in wide} == {0, 1, 2, 3}
    assert max(c.slip.level_mean for c in wide) > 0.09 > 0.01 > min(c.slip.level_mean for c in wide)
    assert {c.lidar.dropout_kinds for c in wide} == {
        (0.0, 1.0, 0.0),
        (0.1, 0.7, 0.2),
        (0.2, 0.5, 0.3),
    }
