"""Bags older ROS 2 tools read: the rosbag2 metadata version, and the storage from the suffix.

Version 8 (the default) stores each topic's offered QoS profiles as one YAML string, the
form ROS 2 Humble's metadata reader takes; version 9 stores a YAML list there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.sim.scan import LaserScan
from transfer import sim_bridge
from transfer.bag_reader import read_bag
from transfer.bag_writer import (
    BAG_VERSIONS,
    DEFAULT_BAG_VERSION,
    BagRecorder,
    check_bag_version,
    resolve_storage,
)

MS = 1_000_000
SCAN = LaserScan(-1.0, 0.1, np.linspace(0.5, 2.5, 21), 0.05, 10.0)


def record(path: Path, n: int = 3, **kwargs) -> BagRecorder:
    with BagRecorder(path, **kwargs) as rec:
        for k in range(1, n + 1):
            rec.write_step(k * 100 * MS, SCAN, (0.1 * k, 0.0, 0.0), (0.1, 0.0), cmd=(0.1, 0.0))
    return rec


def metadata(bag: Path) -> dict:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def test_the_default_version_is_the_one_humble_reads():
    assert DEFAULT_BAG_VERSION == 8 and BAG_VERSIONS == (8, 9)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("version", [None, 8, 9])
def test_each_version_is_written_as_asked_and_reads_back(tmp_path, storage, version):
    bag = tmp_path / "b"
    rec = record(bag, storage=storage, version=version)
    meta = metadata(bag)
    expected = DEFAULT_BAG_VERSION if version is None else version
    assert rec.version == meta["version"] == expected
    assert meta["storage_identifier"] == storage
    qos = [t["topic_metadata"]["offered_qos_profiles"] for t in meta["topics_with_message_count"]]
    assert qos and all(isinstance(q, str if expected == 8 else list) for q in qos)
    data = read_bag(bag)
    assert len(data.scans) == 3
    np.testing.assert_array_equal(data.scans[0].ranges, SCAN.ranges.astype(np.float32))


@pytest.mark.parametrize("version", [0, 5, 7, 10])
def test_a_version_rosbags_cannot_write_is_refused_before_any_file(tmp_path, version):
    with pytest.raises(BagFormatError, match=rf"version {version} cannot be written; use 8 or 9"):
        BagRecorder(tmp_path / "b", version=version)
    assert not (tmp_path / "b").exists()


def test_a_ros1_bag_has_no_rosbag2_version(tmp_path):
    assert BagRecorder(tmp_path / "r.bag").version is None
    with pytest.raises(BagFormatError, match="a ROS 1 bag has none"):
        BagRecorder(tmp_path / "r.bag", version=8)


@pytest.mark.parametrize(
    ("name", "storage", "expected"),
    [
        ("b", None, "sqlite3"),
        ("b.mcap", None, "mcap"),
        ("b.db3", None, "sqlite3"),
        ("b.bag", None, "ros1"),
        ("b", "mcap", "mcap"),
        ("b.mcap", "mcap", "mcap"),
        ("run.2024", "sqlite3", "sqlite3"),  # an unknown suffix is just a directory name
    ],
)
def test_resolve_storage(name, storage, expected):
    assert resolve_storage(Path(name), storage) == expected


@pytest.mark.parametrize(
    ("name", "storage", "match"),
    [
        ("b.mcap", "sqlite3", "'.mcap' names a mcap bag, not storage 'sqlite3'"),
        ("b.db3", "mcap", "'.db3' names a sqlite3 bag, not storage 'mcap'"),
        ("b.mcap", "ros1", "'.mcap' names a mcap bag, not storage 'ros1'"),
        ("b", "ros1", "must end in '.bag'"),
        ("b", "hdf5", "unknown storage 'hdf5'"),
    ],
)
def test_resolve_storage_refuses_a_contradiction(name, storage, match):
    with pytest.raises(BagFormatError, match=match):
        resolve_storage(Path(name), storage)


def test_an_mcap_suffix_makes_an_mcap_bag_not_a_sqlite3_one(tmp_path):
    bag = tmp_path / "x.mcap"
    record(bag)
    assert metadata(bag)["storage_identifier"] == "mcap"
    assert [p.suffix for p in bag.iterdir() if p.name != "metadata.yaml"] == [".mcap"]


def test_messages_name_the_option_they_are_given():
    with pytest.raises(BagFormatError, match="not --storage 'sqlite3'; rename the bag or drop"):
        resolve_storage(Path("x.mcap"), "sqlite3", option="--storage")
    with pytest.raises(BagFormatError, match="--bag-version 3 cannot be written"):
        check_bag_version(3, "sqlite3", "x", option="--bag-version")


# --- d3dwa record ------------------------------------------------------------------------


@pytest.fixture
def fake_episode(monkeypatch):
    """record_episode without the simulator: three steps into the recorder."""

    def episode(world, method, policy, noise, seed, recorder, **_):
        for k in range(1, 4):
            recorder.write_step(k * 100 * MS, SCAN, (0.1 * k, 0.0, 0.0), (0.1, 0.0))
        return None

    monkeypatch.setattr(sim_bridge, "record_episode", episode)


def run(capsys, *argv) -> tuple[int, str]:
    code = main(["record", "--world", "R1", "--method", "dwa1", *map(str, argv)])
    return code, capsys.readouterr().err


def test_record_infers_mcap_from_the_suffix(tmp_path, capsys, fake_episode):
    code, err = run(capsys, "--out", tmp_path / "x.mcap")
    assert code == 0, err
    meta = metadata(tmp_path / "x.mcap")
    assert meta["storage_identifier"] == "mcap" and meta["version"] == DEFAULT_BAG_VERSION


def test_record_bag_version_9(tmp_path, capsys, fake_episode):
    code, err = run(capsys, "--out", tmp_path / "b", "--bag-version", "9")
    assert code == 0, err
    assert metadata(tmp_path / "b")["version"] == 9


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--out", "x.mcap", "--storage", "sqlite3"], "not --storage 'sqlite3'"),
        (["--out", "b", "--bag-version", "7"], "--bag-version 7 cannot be written; use 8 or 9"),
        (["--out", "r.bag", "--bag-version", "8"], "--bag-version 8 is a ROS 2 bag format"),
    ],
)
def test_record_refuses_contradictions_in_one_line_and_writes_nothing(
    tmp_path, capsys, fake_episode, monkeypatch, args, match
):
    monkeypatch.chdir(tmp_path)
    code, err = run(capsys, *args)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("d3dwa: error: ")
    assert match in lines[0]
    assert list(tmp_path.iterdir()) == []
