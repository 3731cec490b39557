"""The per-world figures say which episode each panel is (evaluation seed, noise, a learned
method's training seed), and the horizon's colour bar is in bands: tau takes four values."""

from __future__ import annotations

import shutil

import numpy as np

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation import jobs
from d3dwa_bullet.evaluation.plotting import horizon_colours
from d3dwa_bullet.world.registry import load_world


def test_the_horizon_colours_are_one_band_per_horizon() -> None:
    norm, cmap, ticks = horizon_colours(np.array([2.0, 5.0, np.nan]))
    assert list(ticks) == [2.0, 3.0, 4.0, 5.0] and cmap.N == 4
    bands = [cmap(norm(t)) for t in (2.0, 2.9, 3.1, 3.4, 4.0, 5.0)]
    assert bands[1] == bands[2] == bands[3] != bands[0]  # 2.9 to 3.4 s: the 3 s band
    assert len({bands[0], bands[1], bands[4], bands[5]}) == 4


def test_each_figure_names_the_episode_it_shows(tmp_path, one_second_world, monkeypatch, capsys):
    out = tmp_path / "r"
    argv = ["eval", "--methods", "dwa1", "--worlds", one_second_world, "--seed", "3",
            "--noise", "paper", "--workers", "1", "--out", str(out), "--json"]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    drawn = []
    monkeypatch.setattr(
        "d3dwa_bullet.evaluation.plotting.trajectory_figure",
        lambda world, runs, path, **kw: drawn.append((runs, kw)) or path,
    )
    world = load_world(one_second_world)
    jobs.world_figures(out, [world], ["dwa1"], 3, "paper", {"dwa1": None})
    ((runs, kw),) = drawn
    assert "evaluation seed 3, noise paper)" in kw["title"] and runs[0]["label"] == "dwa1"
    drawn.clear()  # the same log as a learned method's, training seed 2: its panel says so
    learned = jobs.Job(world, "d3dwa", 3, "paper", policy_seed=2)
    shutil.copy(
        out / "logs" / jobs.Job(world, "dwa1", 3, "paper").log_name, out / "logs" / learned.log_name
    )
    jobs.world_figures(out, [world], ["d3dwa"], 3, "paper", {"d3dwa": 2})
    assert [runs[0]["label"] for runs, _ in drawn] == ["d3dwa · seed 2"] * 2  # time and tau
    assert all("noise paper; · seed k: training seed k)" in kw["title"] for _, kw in drawn)
