"""The scan filters: what each removes, what it keeps, and its per-episode state."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.planning.scan_filter import (
    SCAN_FILTERS,
    ScanFilter,
    Speckle,
    TemporalMedian,
    check_scan_filter,
)
from d3dwa_bullet.sim.scan import LaserScan


def scan(ranges, stamp=0):
    return LaserScan(-1.0, 0.01, np.asarray(ranges, dtype=float), 0.05, 10.0, stamp)


def test_the_temporal_median_removes_a_one_scan_phantom_and_keeps_a_wall():
    f = TemporalMedian(3)
    wall = np.full(5, 2.0)
    f(scan(wall))
    f(scan(wall))
    phantom = wall.copy()
    phantom[2] = 0.3  # a spurious return on one scan
    out = f(scan(phantom)).ranges
    np.testing.assert_allclose(out, wall)
    # a real obstacle that stays is seen once it holds the majority of the window
    f(scan(phantom))
    assert f(scan(phantom)).ranges[2] == pytest.approx(0.3)


def test_the_temporal_median_fills_a_dropout_and_keeps_invalid_what_never_returned():
    f = TemporalMedian(3)
    f(scan([2.0, np.inf, 1.0]))
    out = f(scan([np.nan, np.inf, 0.0])).ranges  # NaN and 0 are dropouts, inf is no return
    assert out[0] == 2.0 and np.isinf(out[1]) and out[2] == 1.0
    f.reset()
    out = f(scan([np.nan, 3.0, 1.0])).ranges
    assert np.isinf(out[0]) and out[1] == 3.0  # the state is gone after reset


def test_the_median_shrinks_the_inward_pull_of_range_noise_on_the_nearest_return():
    rng = np.random.default_rng(0)
    raw, filtered = [], []
    f = TemporalMedian(3)
    for t in range(200):
        seen = 1.0 + rng.normal(0.0, 0.05, 60)
        raw.append(seen.min())
        filtered.append(f(scan(seen, t)).ranges.min())
    assert 1.0 - np.mean(raw[3:]) > 0.1  # about two standard deviations inward
    assert 1.0 - np.mean(filtered[3:]) < 0.75 * (1.0 - np.mean(raw[3:]))


def test_speckle_drops_a_lone_return_and_keeps_an_obstacle_edge():
    ranges = np.array([3.0, 3.0, 0.4, 3.0, 3.0, 1.0, 1.02, 1.01, 3.0, 3.0])
    out = Speckle(0.1)(scan(ranges)).ranges
    assert np.isinf(out[2])  # a lone phantom
    np.testing.assert_allclose(out[5:8], ranges[5:8])  # a three-beam obstacle
    np.testing.assert_allclose(out[[0, 1, 3, 4, 8, 9]], ranges[[0, 1, 3, 4, 8, 9]])


def test_chains_by_name_and_bad_names():
    assert ScanFilter("none")(scan([1.0, 2.0])).ranges.tolist() == [1.0, 2.0]
    assert set(SCAN_FILTERS) >= {"none", "median", "speckle", "speckle+median"}
    with pytest.raises(ConfigError, match="unknown scan filter 'mean'; choose one of none"):
        check_scan_filter("mean")
    with pytest.raises(ConfigError, match="unknown scan filter 'x'"):
        EpisodeConfig(scan_filter="x")
    assert EpisodeConfig().scan_filter == "none"
