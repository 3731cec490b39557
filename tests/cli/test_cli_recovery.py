"""--recovery on every command that runs episodes: bad values refused in one line, the two
tracks kept apart on disk, in tables and in compare; the figure and the env."""

from __future__ import annotations

import csv
import hashlib
import json
from pathlib import Path

import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.plotting import draw_recoveries
from d3dwa_bullet.evaluation.results import CSV_FIELDS
from tests.support.cli import refused, run

GOAL_BEHIND = {
    "name": "behind",
    "group": "custom",
    "description": "goal behind the start: the robot loops near it",
    "start": [0.0, 0.0, 0.0],
    "goal": [-0.5, 0.0],
    "time_limit": 15.0,
    "obstacles": [],
}


def header(out: Path) -> list[str]:
    with (out / "results.csv").open(newline="") as fh:
        return next(csv.reader(fh))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


BAD = [
    (["--recovery", "bogus"], "--recovery 'bogus': choose one of none, nav2"),
    (["--recovery", "nav2", "--progress-radius", "0"], "--progress-radius must be a number > 0"),
    (["--recovery", "nav2", "--progress-radius", "-1"], "--progress-radius must be"),
    (["--recovery", "nav2", "--progress-radius", "nan"], "--progress-radius must be"),
    (["--recovery", "nav2", "--progress-window", "-5"], "--progress-window must be"),
    (["--recovery", "nav2", "--progress-window", "0.05"], "shorter than one control step"),
    (["--progress-window", "5"], "--progress-window needs a recovery layer"),
]


@pytest.mark.parametrize(("extra", "message"), BAD)
@pytest.mark.parametrize("command", ["run", "eval", "sweep", "record"])
def test_bad_recovery_values_are_refused_before_anything_runs(
    capsys, tmp_path, one_second_world, command, extra, message
):
    out = tmp_path / "out"
    base = {
        "run": ["run", "--world", one_second_world, "--method", "dwa3"],
        "eval": ["eval", "--worlds", one_second_world, "--methods", "dwa3", "--out", out],
        "sweep": ["sweep", "--worlds", one_second_world, "--layouts", "0", "--axes", "",
                  "--profiles", "none", "--methods", "dwa3", "--out", out],
        "record": ["record", "--world", one_second_world, "--method", "dwa3", "--out", out],
    }[command]  # fmt: skip
    assert message in refused(capsys, *base, *extra)
    assert not out.exists()


def test_a_results_directory_holds_one_recovery_setting(capsys, tmp_path, one_second_world):
    rec, paper = tmp_path / "rec", tmp_path / "paper"
    common = ["--worlds", one_second_world, "--methods", "dwa3", "--workers", "1"]
    assert run(capsys, "eval", *common, "--out", rec, "--recovery", "nav2")[0] == 0
    assert run(capsys, "eval", *common, "--out", paper)[0] == 0
    assert header(rec) == [*CSV_FIELDS, "recovery"] and header(paper) == list(CSV_FIELDS)
    with (rec / "results.csv").open(newline="") as fh:
        assert {r["recovery"] for r in csv.DictReader(fh)} == {"nav2"}
    assert "Recovery layer `nav2`" in (rec / "table.md").read_text()
    assert "Recovery layer" not in (paper / "table.md").read_text()
    for target, option in ((rec, []), (paper, ["--recovery", "nav2"])):
        before = {p.name: digest(p) for p in target.iterdir() if p.is_file()}
        line = refused(capsys, "eval", *common, "--out", target, *option)
        assert "one directory holds one recovery setting" in line
        assert "--recovery nav2" in line and "--recovery none" in line
        assert {p.name: digest(p) for p in target.iterdir() if p.is_file()} == before
    # another progress window is another episode config: refused too, naming the field
    line = refused(
        capsys, "eval", *common, "--out", rec, "--recovery", "nav2", "--progress-window", "5"
    )
    assert "recovery.window 10.0 there, 5.0 here" in line

    code, out, _ = run(capsys, "compare", rec, "--against", paper, "--methods", "dwa3,dwa3")
    words = " ".join(out.split())  # prose lines split to the page's width
    assert code == 0 and f"{rec / 'results.csv'} and {paper / 'results.csv'}" in words
    assert "share only one layout" in out  # one world: no paired test, no NaN p-value
    assert "| DWA III (2,1,1) + recovery nav2 |" in out
    assert "two different methods" in refused(capsys, "compare", rec, "--methods", "dwa3,dwa3")


def test_sweep_and_record_take_the_recovery_layer(capsys, tmp_path, one_second_world):
    out = tmp_path / "sweep"
    argv = ["sweep", "--worlds", one_second_world, "--layouts", "0", "--axes", "",
            "--profiles", "none", "--methods", "dwa3", "--seeds", "1", "--workers", "1",
            "--out", out, "--recovery", "nav2"]  # fmt: skip
    assert run(capsys, *argv)[0] == 0
    assert (
        header(out)[-1] == "recovery" and "Recovery layer `nav2`" in (out / "sweep.md").read_text()
    )
    bag = tmp_path / "bag"
    code, text, _ = run(
        capsys, "record", "--world", one_second_world, "--method", "dwa3", "--out", bag,
        "--recovery", "nav2",
    )  # fmt: skip
    assert code == 0 and "'recovery': 'nav2'" in text and (bag / "metadata.yaml").is_file()


def test_run_plots_the_recovery_steps(capsys, tmp_path):
    world = tmp_path / "behind.yaml"
    world.write_text(yaml.safe_dump(GOAL_BEHIND))
    png = tmp_path / "rec.png"
    code, text, _ = run(
        capsys, "run", "--world", world, "--method", "dwa3", "--recovery", "nav2",
        "--progress-window", "2", "--plot", png, "--json",
    )  # fmt: skip
    summary = json.loads(text)
    assert code == 0 and summary["recovery"] == "nav2"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_draw_recoveries_draws_each_behaviour_that_ran():
    fig, ax = plt.subplots()
    x, y = np.linspace(0, 1, 6), np.zeros(6)
    assert draw_recoveries(ax, x, y, np.array([0, 1, 1, 0, 2])) == {"spin", "back_up"}
    assert draw_recoveries(ax, x, y, np.array([0, 0, 0, 0, 0])) == set()
    assert draw_recoveries(ax, x, y, None) == set()
    plt.close(fig)


def test_env_takes_the_recovery_layer():
    env = gym.make("d3dwa_bullet/D3DWA-v0", recovery="nav2")
    env.reset(seed=0)
    _, _, _, _, info = env.step(0)
    assert info["recovery"] is None  # nothing to recover from on the first step
    assert env.unwrapped.episode_config.recovery.kind == "nav2"
    env.close()
    with pytest.raises(ConfigError, match="unknown recovery 'bogus'"):
        gym.make("d3dwa_bullet/D3DWA-v0", recovery="bogus")


def test_a_results_directory_holds_one_scan_filter(capsys, tmp_path, one_second_world):
    out = tmp_path / "filtered"
    common = ["--worlds", one_second_world, "--methods", "dwa3", "--workers", "1", "--out", out]
    assert run(capsys, "eval", *common, "--scan-filter", "speckle+median")[0] == 0
    meta = json.loads((out / "meta.json").read_text())
    assert meta["config"]["scan_filter"] == "speckle+median"
    assert "**Scan filter `speckle+median`**" in (out / "table.md").read_text()
    line = refused(capsys, "eval", *common)  # resumed without the filter: another config
    assert "scan_filter 'speckle+median' there, 'none' here" in line
    line = refused(capsys, "eval", *common, "--scan-filter", "mean")
    assert "--scan-filter 'mean': choose one of none, median, speckle, speckle+median" in line
