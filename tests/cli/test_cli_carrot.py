"""--carrot: bad values and a carrot without a plan refused in one line; the two rules never share a
results directory; a directory from before the option resumes under ``along``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from tests.support.cli import refused, run


def plans(out: Path) -> set[str]:
    with (out / "results.csv").open(newline="") as fh:
        return {r["global_plan"] for r in csv.DictReader(fh)}


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--global-plan", "scan", "--carrot", "ahead"],
            "--carrot 'ahead': choose one of along, sight",
        ),
        (["--carrot", "sight"], "--carrot sight needs --global-plan scan or map"),
    ],
)
def test_bad_carrot_refused_before_anything_runs(capsys, tmp_path, one_second_world, argv, message):
    out = tmp_path / "out"
    line = refused(
        capsys, "eval", "--worlds", one_second_world, "--methods", "dwa3", "--out", out, *argv
    )
    assert message in line
    assert not out.exists()


def _scan_eval(world):
    """eval's options for DWA III on world with the scan plan, one worker."""
    return ["--worlds", world, "--methods", "dwa3", "--workers", "1", "--global-plan", "scan"]


def test_the_two_rules_never_share_a_directory(capsys, tmp_path, one_second_world):
    sight, along = tmp_path / "sight", tmp_path / "along"
    common = _scan_eval(one_second_world)
    assert run(capsys, "eval", *common, "--carrot", "sight", "--out", sight)[0] == 0
    assert run(capsys, "eval", *common, "--out", along)[0] == 0  # the default: along
    assert plans(sight) == {"scan+sight"} and plans(along) == {"scan"}
    meta = json.loads((sight / "meta.json").read_text())
    assert (
        meta["settings"]["global_plan"] == "scan+sight"
        and meta["config"]["global_plan"]["carrot"] == "sight"
    )
    line = refused(capsys, "eval", *common, "--carrot", "along", "--out", sight)
    assert str(sight) in line
    line = refused(capsys, "eval", *common, "--carrot", "sight", "--out", along)
    assert str(along) in line


def test_a_directory_from_before_the_option_resumes_under_along(capsys, tmp_path, one_second_world):
    out = tmp_path / "old"
    common = _scan_eval(one_second_world)
    assert run(capsys, "eval", *common, "--seeds", "1", "--out", out)[0] == 0
    meta_path = out / "meta.json"
    meta = json.loads(meta_path.read_text())
    del meta["config"]["global_plan"]["carrot"]  # as written before GlobalPlanParams.carrot
    meta_path.write_text(json.dumps(meta))
    assert run(capsys, "eval", *common, "--seeds", "2", "--out", out)[0] == 0
    assert plans(out) == {"scan"}
    line = refused(capsys, "eval", *common, "--seeds", "2", "--carrot", "sight", "--out", out)
    assert "carrot" in line or "global-plan" in line
