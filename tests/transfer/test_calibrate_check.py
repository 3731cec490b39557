"""Issue 16 item 4: an episode simulated under the profile calibrated from a source robot's
bag is closer to that source, sector by sector, than one under the base profile."""

from __future__ import annotations

from pathlib import Path

from tools.experiments.calibration_check import check


def test_calibrated_profile_is_closer_to_the_source_than_its_base(tmp_path: Path) -> None:
    result = check(tmp_path, "H1", "dwa3", "real", 8.0, (11, 12))
    d = result["mean_abs_difference_to_source"]
    for key in ("valid", "nan", "neg_inf", "zero", "out_of_range", "noise_mm"):
        assert d["calibrated"][key] < d["base"][key], (key, d)
    assert d["calibrated"]["valid"] < 0.5 * d["base"]["valid"]
    assert "lidar.dropout_sector_scale" in result["calibrate"]["estimated"]
