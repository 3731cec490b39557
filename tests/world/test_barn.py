"""BARN's worlds rebuilt from the shipped grids: the cylinders of the original files, the splits,
the reference path lengths, and a checked manifest."""

from __future__ import annotations

import gzip
import itertools
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError, UnknownNameError, WorldFormatError
from d3dwa_bullet.learning.tasks import check_training_world
from d3dwa_bullet.resources import barn_dir
from d3dwa_bullet.world import barn
from d3dwa_bullet.world.barn import (
    barn_split,
    barn_split_ids,
    barn_world,
    path_length,
    read_world_file,
    recover_grid,
    written_cells,
)
from d3dwa_bullet.world.model import Cylinder
from d3dwa_bullet.world.registry import load_world
from d3dwa_bullet.world.sdf import load_sdf_world

FIXTURES = Path(__file__).parent / "fixtures" / "barn"
FIXTURE_IDS = sorted(int(p.name.split("_")[1].split(".")[0]) for p in FIXTURES.glob("*.gz"))


def _cylinders(obstacles) -> set[tuple[float, float, float, float]]:
    assert all(isinstance(ob, Cylinder) for ob in obstacles)
    keys = {(ob.center[0], ob.center[1], ob.radius, ob.height) for ob in obstacles}
    assert len(keys) == len(obstacles)
    return keys


def test_fixtures_are_present():
    assert FIXTURE_IDS == [0, 57, 98, 150, 299]


@pytest.mark.parametrize("index", FIXTURE_IDS)
def test_rebuilt_world_has_exactly_the_original_files_cylinders(index, tmp_path):
    path = tmp_path / f"world_{index}.world"
    path.write_bytes(gzip.decompress((FIXTURES / f"world_{index}.world.gz").read_bytes()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ground plane and light: not obstacles
        original = load_sdf_world(path)
    rebuilt = barn_world(index)
    assert _cylinders(rebuilt.obstacles) == _cylinders(original.obstacles)
    assert len(rebuilt.obstacles) == len(original.obstacles) > 96


def test_world_has_barns_task_and_names():
    w = load_world("barn-17")
    assert (w.name, w.source, w.group) == ("BARN-17", "barn:17", "barn-train")
    assert w.start == (-2.25, 3.0, pytest.approx(np.pi / 2))
    assert w.goal == (-2.25, 13.0) and w.time_limit == 100.0
    assert load_world("BARN-0").group == "barn-challenge"


def test_reference_length_is_the_polyline_through_run_py_cells():
    _, path = read_world_file(barn.world_file(0))
    pts = [(-2.25, 3.0)] + [(0.15 * px - 4.575, 0.15 * py + 5.075) for px, py in path]
    pts.append((-2.25, 13.0))
    expected = sum(np.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(pts))
    assert barn_world(0).reference_length == pytest.approx(expected, rel=1e-12)


def test_path_lengths_span_barns_published_range():
    lengths = [path_length(read_world_file(barn.world_file(i))[1]) for i in range(300)]
    assert round(min(lengths), 2) == 10.05 and round(max(lengths), 2) == 13.74
    assert round(float(np.median(lengths)), 2) == 11.23


def test_every_grid_writes_back_and_keeps_its_path_free():
    for i in range(300):
        grid, path = read_world_file(barn.world_file(i))
        written = written_cells(grid)
        assert np.array_equal(recover_grid(written), grid), i
        assert not grid[path[:, 0], path[:, 1]].any(), i
        assert grid[0].all() and grid[-1].all(), i


def test_recovery_fills_a_hidden_core_and_keeps_a_sealed_pocket_free():
    block = np.zeros((30, 30), dtype=bool)
    block[10:15, 10:15] = True  # a 5x5 block: its 3x3 core is not written
    assert written_cells(block).sum() == 16
    assert np.array_equal(recover_grid(written_cells(block)), block)
    ring = block.copy()
    ring[12, 12] = False  # filling the pocket would hide the ring's inner cells
    assert np.array_equal(recover_grid(written_cells(ring)), ring)


def test_splits():
    challenge, train, every = (barn_split_ids(s) for s in ("challenge", "train", "all"))
    assert challenge == tuple(range(0, 300, 6)) and len(train) == 250
    assert set(challenge).isdisjoint(train) and set(challenge) | set(train) == set(every)
    assert every == tuple(range(300))
    assert barn_split(294) == "challenge" and barn_split(295) == "train"
    with pytest.raises(UnknownNameError, match="split 'test'"):
        barn_split_ids("test")


def test_training_refuses_the_challenge_split():
    with pytest.raises(ConfigError, match="BARN-6"):
        check_training_world(barn_world(6))
    assert check_training_world(barn_world(7)).name == "BARN-7"


@pytest.mark.parametrize("name", ["BARN-300", "barn-1000", "BARN--1"])
def test_unknown_ids_are_refused(name):
    with pytest.raises(UnknownNameError, match="BARN"):
        load_world(name)


@pytest.mark.parametrize("bad", [-1, 300, 2.0, True])
def test_bad_numbers_are_refused(bad):
    with pytest.raises(UnknownNameError, match="BARN world"):
        barn_world(bad)


@pytest.fixture
def data_copy(tmp_path, monkeypatch):
    folder = tmp_path / "barn"
    shutil.copytree(barn_dir(), folder)
    monkeypatch.setattr(barn, "barn_dir", lambda: folder)
    return folder


def test_a_tampered_grid_is_refused(data_copy):
    path = data_copy / "world_5.txt"
    path.write_text(path.read_text().replace("1", "0", 40))
    with pytest.raises(WorldFormatError, match=r"world_5\.txt: sha256 [0-9a-f]{64} does not match"):
        barn_world(5)
    assert barn_world(4).name == "BARN-4"


def test_a_truncated_grid_is_refused(data_copy):
    path = data_copy / "world_5.txt"
    path.write_bytes(path.read_bytes()[:500])
    with pytest.raises(WorldFormatError, match="world_5.txt: sha256"):
        barn_world(5)


def test_a_tampered_manifest_is_refused(data_copy):
    sums = data_copy / "SHA256SUMS"
    lines = sums.read_text().splitlines()
    sums.write_text("\n".join(ln for ln in lines if not ln.endswith(" world_8.txt")) + "\n")
    with pytest.raises(WorldFormatError, match="world_8.txt: .*no entry"):
        barn_world(8)
