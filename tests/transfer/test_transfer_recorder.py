"""BagRecorder: overwrite policy, float32 scans, partial bags after a failure."""

import numpy as np
import pytest

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.sim.scan import LaserScan
from transfer.bag_reader import read_bag
from transfer.bag_writer import BagRecorder, quantize_scan

MS = 1_000_000
SCAN = LaserScan(-2.0943951023931953, 0.017453292519943295, np.linspace(0.1, 3.3, 241), 0.05, 10.0)


def record(path, n=3, **kwargs):
    with BagRecorder(path, **kwargs) as rec:
        for k in range(1, n + 1):
            rec.write_step(k * 100 * MS, SCAN, (0.1 * k, 0.0, 0.0), (0.1, 0.0))


@pytest.mark.parametrize(("storage", "name"), [("sqlite3", "b"), ("mcap", "m"), ("ros1", "r.bag")])
def test_refuses_to_overwrite_unless_asked(tmp_path, storage, name):
    record(tmp_path / name, storage=storage)
    with pytest.raises(BagFormatError, match="exists; refusing to overwrite"):
        record(tmp_path / name, storage=storage)
    record(tmp_path / name, n=5, storage=storage, overwrite=True)
    assert len(read_bag(tmp_path / name).scans) == 5


def test_overwrite_never_deletes_a_non_bag_directory(tmp_path):
    (tmp_path / "precious").mkdir()
    (tmp_path / "precious" / "notes.txt").write_text("keep me")
    with pytest.raises(BagFormatError, match="does not look like a bag"):
        record(tmp_path / "precious", overwrite=True)
    assert (tmp_path / "precious" / "notes.txt").exists()


def test_ros1_needs_a_bag_suffix_and_a_bag_suffix_means_ros1(tmp_path):
    with pytest.raises(BagFormatError, match="must end in '.bag'"):
        BagRecorder(tmp_path / "x", storage="ros1")
    assert BagRecorder(tmp_path / "x.bag").storage == "ros1"  # inferred from the suffix
    with pytest.raises(BagFormatError, match="'.bag' names a ros1 bag, not storage 'sqlite3'"):
        BagRecorder(tmp_path / "x.bag", storage="sqlite3")


def test_scans_are_stored_as_float32_and_quantize_scan_predicts_them(tmp_path):
    record(tmp_path / "b", n=1)
    got = read_bag(tmp_path / "b").scans[0]
    assert not np.array_equal(got.ranges, SCAN.ranges)  # float64 detail is lost ...
    expected = quantize_scan(SCAN)
    np.testing.assert_array_equal(got.ranges, expected.ranges)  # ... exactly as predicted
    assert got.angle_min == expected.angle_min
    assert got.angle_increment == expected.angle_increment
    assert (got.range_min, got.range_max) == (expected.range_min, expected.range_max)


def test_failure_inside_the_recorder_keeps_a_readable_bag(tmp_path):
    with pytest.raises(RuntimeError, match="sim crashed"), BagRecorder(tmp_path / "b") as rec:
        for k in range(1, 4):
            rec.write_step(k * 100 * MS, SCAN, (0.0, 0.0, 0.0), (0.0, 0.0))
        raise RuntimeError("sim crashed")
    assert len(read_bag(tmp_path / "b").scans) == 3


def test_params_need_five_values(tmp_path):
    with BagRecorder(tmp_path / "b") as rec, pytest.raises(BagFormatError, match="got 3 values"):
        rec.write_params(MS, (1.0, 2.0, 3.0))
