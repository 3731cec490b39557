"""--global-plan on the commands that run episodes: bad values refused in one line, runs with and
without a global plan kept apart on disk, the summary's column, the figure and the env."""

from __future__ import annotations

import csv
import hashlib
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.results import CSV_FIELDS, load_log
from d3dwa_bullet.planning.global_plan import STATUSES, logged_paths
from tests.support.cli import refused, run


def header(out: Path) -> list[str]:
    with (out / "results.csv").open(newline="") as fh:
        return next(csv.reader(fh))


def digests(out: Path) -> dict[str, str]:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in out.iterdir() if p.is_file()
    }


@pytest.mark.parametrize("value", ["bogus", "Scan", ""])
@pytest.mark.parametrize("command", ["run", "eval", "sweep", "record"])
def test_bad_global_plan_values_are_refused_before_anything_runs(
    capsys, tmp_path, one_second_world, command, value
):
    out = tmp_path / "out"
    base = {
        "run": ["run", "--world", one_second_world, "--method", "dwa3"],
        "eval": ["eval", "--worlds", one_second_world, "--methods", "dwa3", "--out", out],
        "sweep": ["sweep", "--worlds", one_second_world, "--layouts", "0", "--axes", "",
                  "--profiles", "none", "--methods", "dwa3", "--out", out],
        "record": ["record", "--world", one_second_world, "--method", "dwa3", "--out", out],
    }[command]  # fmt: skip
    line = refused(capsys, *base, "--global-plan", value)
    assert f"--global-plan {value!r}: choose one of none, scan, map" in line
    assert not out.exists()


def test_a_results_directory_holds_one_global_plan_setting(capsys, tmp_path, one_second_world):
    planned, plain = tmp_path / "planned", tmp_path / "plain"
    common = ["--worlds", one_second_world, "--methods", "dwa3", "--workers", "1"]
    assert run(capsys, "eval", *common, "--out", planned, "--global-plan", "scan")[0] == 0
    assert run(capsys, "eval", *common, "--out", plain)[0] == 0
    assert header(planned) == [*CSV_FIELDS, "global_plan"] and header(plain) == list(CSV_FIELDS)
    with (planned / "results.csv").open(newline="") as fh:
        assert {r["global_plan"] for r in csv.DictReader(fh)} == {"scan"}
    meta = json.loads((planned / "meta.json").read_text())
    assert (
        meta["settings"]["global_plan"] == "scan"
        and meta["config"]["global_plan"]["kind"] == "scan"
    )
    for target, option in (
        (planned, []),
        (plain, ["--global-plan", "scan"]),
        (planned, ["--global-plan", "map"]),
    ):
        before = digests(target)
        line = refused(capsys, "eval", *common, "--out", target, *option)
        assert "--out" in line and "\n" not in line.strip()
        assert digests(target) == before
    log = load_log(next((planned / "logs").iterdir()))
    assert set(np.unique(log["plan_status"])) <= set(range(len(STATUSES)))
    assert len(log["plan_status"]) == len(log["true_x"]) and int(log["plan_replans"]) >= 1
    assert logged_paths(log) and logged_paths(log)[0].shape[1] == 2


def test_run_reports_the_global_plan_and_plots_its_paths(capsys, tmp_path):
    png = tmp_path / "plan.png"
    code, text, _ = run(
        capsys, "run", "--world", "TS1", "--method", "dwa3", "--global-plan", "map",
        "--time-limit", "3", "--plot", png, "--json",
    )  # fmt: skip
    summary = json.loads(text)
    assert code == 0 and summary["global_plan"] == "map"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    code, text, _ = run(
        capsys, "run", "--world", "TS1", "--method", "dwa3", "--time-limit", "1", "--json"
    )
    assert code == 0 and "global_plan" not in json.loads(text)


def test_sweep_and_record_take_the_global_plan(capsys, tmp_path, one_second_world):
    out = tmp_path / "sweep"
    argv = ["sweep", "--worlds", one_second_world, "--layouts", "0", "--axes", "",
            "--profiles", "none", "--methods", "dwa3", "--seeds", "1", "--workers", "1",
            "--out", out, "--global-plan", "scan"]  # fmt: skip
    assert run(capsys, *argv)[0] == 0
    assert header(out)[-1] == "global_plan"
    bag = tmp_path / "bag"
    code, text, _ = run(
        capsys, "record", "--world", one_second_world, "--method", "dwa3", "--out", bag,
        "--global-plan", "scan",
    )  # fmt: skip
    assert code == 0 and (bag / "metadata.yaml").is_file()


def test_env_takes_the_global_plan():
    env = gym.make("d3dwa_bullet/D3DWA-v0", global_plan="scan")
    env.reset(seed=0)
    env.step(0)
    assert env.unwrapped.episode_config.global_plan.kind == "scan"
    env.close()
    with pytest.raises(ConfigError, match="--global-plan 'bogus'"):
        gym.make("d3dwa_bullet/D3DWA-v0", global_plan="bogus")
