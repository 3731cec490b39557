"""The per-sector lidar dropout tables that ``d3dwa calibrate`` writes: off by default (bit for
bit today's noise), per-sector rates and kinds when set, and parsed by the profile loader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ConfigError, ProfileError
from d3dwa_bullet.sim.noise import NoiseModel, beam_sector_index
from d3dwa_bullet.sim.noise_config import (
    OUT_OF_RANGE_FACTOR,
    LidarNoiseConfig,
    NoiseConfig,
)
from randomization.profiles import load_profile

N = 481  # the simulated lidar's beams: 240 deg at 0.5 deg
TRUE = np.linspace(0.5, 4.0, N)
SCALE = (4.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
KINDS = (
    (1.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 1.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 1.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 1.0),
    (0.2, 0.2, 0.2, 0.2, 0.2),
    (0.5, 0.5, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.5, 0.5),
)


def corrupt(lidar: LidarNoiseConfig, scans: int = 200, seed: int = 4) -> np.ndarray:
    model = NoiseModel(NoiseConfig(lidar=lidar), seed=seed)
    return np.stack([model.corrupt_ranges(TRUE, 0.05, 10.0) for _ in range(scans)])


def test_sector_index_matches_the_observation_sectors() -> None:
    idx = beam_sector_index(N, 8)
    assert idx[0] == 0 and idx[-1] == 7
    assert np.bincount(idx).tolist() == [60] * 7 + [61]  # 30 deg each, the end beam in the last


def test_tables_off_is_bit_identical_to_uniform_dropout() -> None:
    base = dict(range_std=0.01, dropout_prob=0.2, dropout_kinds=(0.2, 0.5, 0.3))
    a = corrupt(LidarNoiseConfig(**base))
    b = corrupt(LidarNoiseConfig(**base, dropout_sector_scale=None, dropout_sector_kinds=None))
    assert np.array_equal(a, b, equal_nan=True)
    assert NoiseConfig(lidar=LidarNoiseConfig(**base)).to_dict()["lidar"].keys() == {
        "range_std", "dropout_prob", "dropout_kinds", "spurious_prob", "spurious_min",
        "spurious_max",
    }  # fmt: skip


def test_sector_scale_sets_each_sector_rate() -> None:
    out = corrupt(LidarNoiseConfig(dropout_prob=0.1, dropout_sector_scale=SCALE))
    dropped = ~np.isfinite(out) | (out == 0.0)
    sector = beam_sector_index(N, 8)
    rate = np.array([dropped[:, sector == k].mean() for k in range(8)])
    assert rate[0] == pytest.approx(0.4, abs=0.02)
    assert rate[1] == 0.0
    assert rate[2:] == pytest.approx(0.1, abs=0.015)


def test_sector_kinds_write_every_kind_where_asked() -> None:
    out = corrupt(LidarNoiseConfig(dropout_prob=1.0, dropout_sector_kinds=KINDS), scans=40)
    sector = beam_sector_index(N, 8)
    assert np.isnan(out[:, sector == 0]).all()
    assert np.isposinf(out[:, sector == 1]).all()
    assert np.isneginf(out[:, sector == 2]).all()
    assert (out[:, sector == 3] == 0.0).all()
    assert (out[:, sector == 4] == OUT_OF_RANGE_FACTOR * 10.0).all()
    mixed = out[:, sector == 5]
    for hit in (np.isnan(mixed), np.isposinf(mixed), np.isneginf(mixed), mixed == 0.0):
        assert hit.mean() == pytest.approx(0.2, abs=0.03)


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"dropout_sector_scale": (1.0, -0.5)}, "dropout_sector_scale"),
        ({"dropout_sector_scale": ()}, "dropout_sector_scale"),
        ({"dropout_sector_kinds": ((0.5, 0.5, 0.5, 0.0, 0.0),)}, r"dropout_sector_kinds\[0\]"),
        ({"dropout_sector_kinds": ((1.0, 0.0, 0.0),)}, r"dropout_sector_kinds\[0\]"),
        (
            {"dropout_sector_scale": (1.0, 1.0), "dropout_sector_kinds": ((1, 0, 0, 0, 0),)},
            "has 1 rows",
        ),
    ],
)
def test_bad_tables_name_the_field(kwargs: dict, needle: str) -> None:
    with pytest.raises(ConfigError, match=needle):
        LidarNoiseConfig(**kwargs)


def write_profile(tmp_path: Path, lidar_extra: dict, **top) -> Path:
    data = yaml.safe_load(Path(load_profile("real").source).read_text())
    data["params"]["lidar"].update(lidar_extra)
    data.update(top)
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_profile_with_tables_and_sensor_section_round_trips(tmp_path: Path) -> None:
    tables = {"dropout_sector_scale": list(SCALE), "dropout_sector_kinds": [list(r) for r in KINDS]}
    path = write_profile(tmp_path, tables, sensor={"beams": 360, "fov_deg": 359.0})
    config = load_profile(path).sample(np.random.default_rng(0))
    assert config.lidar.dropout_sector_scale == SCALE
    assert config.lidar.dropout_sector_kinds == KINDS
    again = NoiseConfig.from_dict(config.to_dict())
    assert again == config


def test_profile_without_tables_samples_as_before() -> None:
    profile = load_profile("real")
    config = profile.sample(np.random.default_rng(3))
    assert config.lidar.dropout_sector_scale is None and config.lidar.dropout_sector_kinds is None


@pytest.mark.parametrize(
    "extra, top, needle",
    [
        ({"dropout_sector_scale": {"uniform": [0, 1]}}, {}, "fixed list"),
        ({"dropout_sector_scale": [1.0, -1.0]}, {}, "dropout_sector_scale"),
        ({}, {"sensor": [1, 2]}, "'sensor' must be a mapping"),
        (
            {"dropout_sector_scale": [1.0], "dropout_sector_kinds": [[1, 0, 0, 0, 0]] * 2},
            {},
            "sampled an invalid config",
        ),
    ],
)
def test_profile_refuses_bad_tables(tmp_path: Path, extra: dict, top: dict, needle: str) -> None:
    with pytest.raises(ProfileError, match=needle):
        load_profile(write_profile(tmp_path, extra, **top))
