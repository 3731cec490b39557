"""compare_scans: per-sector dropout counts and noise on synthetic bags with known answers."""

import math

import numpy as np
import pytest

from d3dwa_bullet.sim.scan import LaserScan
from transfer.bag_writer import BagRecorder
from transfer.compare import (
    READING_CLASSES,
    classify_readings,
    compare_scans,
    format_scan_comparison,
)
from transfer.synthetic import Corridor, write_corridor_bag

MS = 1_000_000
N_SCANS = 4
# 240 beams, one per degree at -119.5 .. +119.5 deg: beam i lies in sector i // 30.
ANGLE_MIN = math.radians(-119.5)
INC = math.radians(1.0)
# Sector -> (class, beams per scan) planted in every scan.
PLANTED = {
    0: ("nan", 3),
    1: ("pos_inf", 2),
    2: ("neg_inf", 1),
    3: ("zero", 4),
    4: ("out_of_range", 5),
}
VALUE = {"nan": np.nan, "pos_inf": np.inf, "neg_inf": -np.inf, "zero": 0.0}


def planted_bag(path):
    with BagRecorder(path) as rec:
        for k in range(1, N_SCANS + 1):
            r = np.full(240, 2.0)
            for sector, (kind, n) in PLANTED.items():
                beams = sector * 30 + np.arange(n)
                if kind == "out_of_range":
                    r[beams] = [0.01, 0.02, 11.0, 20.0, 1e9]  # below range_min or above range_max
                else:
                    r[beams] = VALUE[kind]
            rec.write_scan(k * 100 * MS, LaserScan(ANGLE_MIN, INC, r, 0.05, 10.0, k * 100 * MS))


def test_classes_are_exclusive_and_exhaustive():
    r = np.array([np.nan, np.inf, -np.inf, 0.0, 0.01, 1.0, 11.0, -1.0])
    masks = classify_readings(r, 0.05, 10.0)
    stacked = np.stack([masks[c] for c in ("valid", *READING_CLASSES)])
    assert (stacked.sum(axis=0) == 1).all()
    assert masks["valid"].tolist() == [False] * 5 + [True, False, False]
    assert masks["out_of_range"].tolist() == [False] * 4 + [True, False, True, True]


def test_dropout_kinds_are_counted_per_sector(tmp_path):
    planted_bag(tmp_path / "a")
    write_corridor_bag(tmp_path / "b", n_scans=3)
    result = compare_scans(tmp_path / "a", tmp_path / "b")
    a = result["a"]
    assert a["scans"] == N_SCANS and a["outside_fov"] == 0
    for s in a["sectors"]:
        kind, n = PLANTED.get(s["sector"], (None, 0))
        assert s["beams"] == 30 * N_SCANS
        for c in READING_CLASSES:
            assert s[c] == (n * N_SCANS if c == kind else 0), (s["sector"], c)
        assert s["valid"] == (30 - n) * N_SCANS
        assert s["valid_ratio"] == pytest.approx((30 - n) / 30)
        assert s["noise_std"] == 0.0  # identical consecutive scans
    total = a["total"]
    assert total["beams"] == 240 * N_SCANS
    assert total["nan"] == 3 * N_SCANS and total["out_of_range"] == 5 * N_SCANS
    b = result["b"]
    assert b["total"]["valid_ratio"] == 1.0


def test_noise_estimate_matches_the_injected_noise(tmp_path):
    sigma = 0.01
    write_corridor_bag(tmp_path / "a", n_scans=20, corridor=Corridor(speed=0.0), noise_std=sigma)
    write_corridor_bag(tmp_path / "b", n_scans=20, corridor=Corridor(speed=0.0))
    result = compare_scans(tmp_path / "a", tmp_path / "b")
    assert result["a"]["total"]["noise_std"] == pytest.approx(sigma, rel=0.1)
    for s in result["a"]["sectors"]:
        assert s["noise_std"] == pytest.approx(sigma, rel=0.3)
    assert result["b"]["total"]["noise_std"] == 0.0


def test_markdown_table(tmp_path):
    planted_bag(tmp_path / "a")
    write_corridor_bag(tmp_path / "b", n_scans=2)
    table = format_scan_comparison(compare_scans(tmp_path / "a", tmp_path / "b"))
    lines = table.splitlines()
    assert lines[2].startswith("| sector | deg | beams | valid | NaN | +inf | -inf | 0.0 |")
    assert len([ln for ln in lines if ln.startswith("| ")]) == 1 + 8 + 1
    row0 = lines[4]
    assert row0.startswith("| 0 | -120..-90 | 120 / ")
    assert "| 12 / 0 |" in row0  # 3 NaN x 4 scans in bag a, none in bag b
    assert lines[-1].startswith("| all |")
