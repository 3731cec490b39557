"""``d3dwa drive --global-plan``'s refusals: one line, exit 2, before anything connects (the
address given is one no robot answers, and no --record bag is left behind)."""

from __future__ import annotations

import pytest

from tests.support.cli import refused

NOBODY = "127.0.0.1:1"


def drive_refused(capsys, tmp_path, *extra) -> str:
    bag = tmp_path / "bag"
    line = refused(
        capsys,
        "drive",
        "--kachaka",
        NOBODY,
        "--goal",
        "1,0",
        "--method",
        "dwa3",
        "--record",
        bag,
        *extra,
    )
    assert not bag.exists() and "connect" not in line and NOBODY not in line
    return line


@pytest.mark.parametrize("value", ["bogus", "Map", ""])
def test_an_unknown_global_plan_is_refused(capsys, tmp_path, value):
    line = drive_refused(capsys, tmp_path, "--global-plan", value)
    assert f"--global-plan {value!r}: choose one of none, scan, map" in line


def test_map_without_a_map_file_is_refused_naming_the_option(capsys, tmp_path):
    line = drive_refused(capsys, tmp_path, "--global-plan", "map")
    assert "--global-plan map on drive needs --map FILE" in line


@pytest.mark.parametrize("plan", ["scan", "none"])
def test_a_map_file_without_the_map_plan_is_refused(capsys, tmp_path, plan):
    line = drive_refused(capsys, tmp_path, "--global-plan", plan, "--map", tmp_path / "any.yaml")
    assert f"is read only with --global-plan map (got {plan})" in line


def test_a_map_file_that_does_not_load_is_refused_naming_the_file(capsys, tmp_path):
    missing = tmp_path / "missing.yaml"
    line = drive_refused(capsys, tmp_path, "--global-plan", "map", "--map", missing)
    assert f"--map {missing} does not load" in line
    broken = tmp_path / "broken.yaml"
    broken.write_text("image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                      "occupied_thresh: 0.65\nfree_thresh: 0.196\n")  # fmt: skip
    line = drive_refused(capsys, tmp_path, "--global-plan", "map", "--map", broken)
    assert f"--map {broken} does not load" in line and "nowhere.pgm" in line
