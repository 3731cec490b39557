"""Noise sweep: conditions, unseen layouts, statistics, outputs, resume, bad input."""

from __future__ import annotations

import csv
import functools
import json
import math
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from tqdm import tqdm

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.episode_metrics import SCORE_FORM
from d3dwa_bullet.errors import D3DWAError, ResultsError
from d3dwa_bullet.evaluation import jobs as evaluation
from d3dwa_bullet.evaluation import sweep
from d3dwa_bullet.evaluation.jobs import evaluate
from d3dwa_bullet.evaluation.noise_axes import AXES
from d3dwa_bullet.evaluation.report import eval_markdown
from d3dwa_bullet.evaluation.stats import t_interval, wilson_interval
from d3dwa_bullet.evaluation.sweep import (
    SWEEP_FIELDS,
    SweepSettings,
    conditions,
    layout_titles,
    read_sweep,
    run_sweep,
    sweep_jobs,
    sweep_markdown,
    sweep_worlds,
)
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.sim.noise_config import NoiseConfig
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from d3dwa_bullet.world.registry import load_world


def tiny_settings(world: str, **kw) -> SweepSettings:
    """2 methods x 1 world x (baseline + 2 axis levels + 1 profile) x 1 seed = 8 episodes."""
    base = dict(methods=("dwa1", "dwa3"), worlds=(world,), styles=(), layouts=0, seeds=1,
                levels=1, axes=("lidar_dropout", "slip"), profiles=("none", "real"))  # fmt: skip
    return SweepSettings(**(base | kw))


def test_conditions_share_one_noise_free_baseline():
    conds = conditions(SweepSettings(methods=("dwa1",), levels=4))
    labels = [c.noise for c in conds]
    assert labels[0] == "none" and labels.count("none") == 1 and len(set(labels)) == len(labels)
    assert len(conds) == 1 + 4 * len(AXES) + 3  # baseline, levels, paper/real/harsh
    for c in conds:
        if c.noise_config is not None:
            cfg = NoiseConfig.from_dict(json.loads(c.noise_config))
            assert cfg.enabled and c.level > 0
    assert [c.level for c in conds if c.axis == "lidar_dropout"] == [0.125, 0.25, 0.375, 0.5]


@pytest.mark.parametrize("name", list(AXES))
def test_each_axis_turns_on_only_its_own_model(name):
    cfg = AXES[name].build(AXES[name].harsh)
    on = [g for g in ("slip", "lidar", "odometry", "imu", "latency", "physics", "pose_fix")
          if getattr(cfg, g).enabled]  # fmt: skip
    assert on == [{"lidar_dropout": "lidar", "lidar_range": "lidar"}.get(name, name)]
    assert not AXES[name].build(0.0).enabled  # level 0 is the noise-free baseline


def test_unseen_layouts_come_from_outside_the_training_seed_range():
    pairs = sweep_worlds(SweepSettings(methods=("dwa1",), worlds=("R1",), layouts=1))
    names = [w.name for w, _ in pairs]
    assert names == ["R1", *(f"R{i}-style-s{UNSEEN_LAYOUT_SEED_BASE}" for i in (1, 2, 3))]
    assert [g for _, g in pairs] == ["shipped"] + ["generated"] * 3
    assert UNSEEN_LAYOUT_SEED_BASE >= 2**31  # training draws generator seeds in [0, 2^31)


def test_without_noise_only_the_random_choosers_draw_from_the_episode_seed(one_second_world):
    world = load_world(one_second_world)
    # run one by one: evaluate runs a noise-free fixed method once (evaluation.repeats)
    logs = {(m, seed): evaluation.run_job(evaluation.Job(world, m, seed)).log
            for m in ("dwa3", "random") for seed in (0, 1)}  # fmt: skip
    assert np.array_equal(logs[("dwa3", 0)]["action"], logs[("dwa3", 1)]["action"])
    for k in ("true_x", "true_y", "v_cmd", "w_cmd"):
        assert np.array_equal(logs[("dwa3", 0)][k], logs[("dwa3", 1)][k]), k
    assert not np.array_equal(logs[("random", 0)]["action"], logs[("random", 1)]["action"])


def test_the_page_says_when_noise_free_cells_ran_once_for_several_seeds(
    tiny_sweep, one_second_world
):
    _, rows, _ = tiny_sweep
    note = "Deterministic without noise: run once per layout"
    assert note not in sweep_markdown(rows, tiny_settings(one_second_world))
    assert note in sweep_markdown(rows, tiny_settings(one_second_world, seeds=2))
    random_only = tiny_settings(one_second_world, seeds=2, methods=("random",))
    assert note not in sweep_markdown([], random_only)
    noise_free = [r for r in rows if r["noise"] == "none"]
    world = noise_free[0]["world"]
    assert note in eval_markdown(noise_free, ["dwa1", "dwa3"], [world], [0, 1], "none")
    assert note not in eval_markdown(noise_free, ["dwa1", "dwa3"], [world], [0], "none")
    assert note not in eval_markdown(noise_free, ["dwa1", "dwa3"], [world], [0, 1], "real")


def test_worlds_given_by_generated_name_are_not_filed_as_shipped():
    named = f"R2-style-s{UNSEEN_LAYOUT_SEED_BASE + 7}"
    settings = SweepSettings(methods=("dwa1",), worlds=("r1", named), layouts=0)
    assert [g for _, g in sweep_worlds(settings)] == ["shipped", "given"]
    titles = layout_titles(settings)
    assert titles == {"shipped": "shipped worlds: r1", "given": f"worlds given: {named}"}


def test_wilson_interval_always_contains_the_observed_rate():
    # A bound a few ulp on the wrong side of k / n once made a negative error bar and
    # crashed matplotlib after a whole sweep had run.
    for n in range(1, 300):
        for k in range(n + 1):
            lo, hi = wilson_interval(k, n)
            assert 0.0 <= lo <= k / n <= hi <= 1.0, (k, n, lo, hi)


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson_interval(5, 10)
    assert (lo, hi) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


def test_t_interval():
    mean, lo, hi = t_interval([10.0, 12.0, 14.0])
    assert mean == 12.0 and hi - mean == pytest.approx(4.303 * 2 / math.sqrt(3), rel=1e-3)
    assert math.isnan(t_interval([3.0])[1]) and math.isnan(t_interval([])[0])


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"methods": ("dwa9",)}, "unknown method 'dwa9'"),
        ({"axes": ("gravity",)}, "unknown noise axis 'gravity'"),
        ({"profiles": ("bogus",)}, "bogus"),
        ({"levels": 0}, "--levels"),
        ({"seeds": 0}, "--seeds"),
    ],
)
def test_settings_refuse_bad_input(kw, message):
    with pytest.raises(D3DWAError, match=message):
        SweepSettings(**({"methods": ("dwa1",)} | kw))


@pytest.fixture(scope="module")
def tiny_sweep(one_second_world, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    rows, complete = run_sweep(tiny_settings(one_second_world), out, progress=False)
    return out, rows, complete


def test_sweep_writes_rows_tables_and_one_plot_per_axis(tiny_sweep):
    out, rows, complete = tiny_sweep
    assert complete and len(rows) == 8
    with (out / "results.csv").open() as fh:
        assert tuple(next(csv.reader(fh))) == SWEEP_FIELDS
    assert Counter(r["axis"] for r in rows) == {"none": 2, "lidar_dropout": 2, "slip": 2,
                                                "profile": 2}  # fmt: skip
    assert {r["level"] for r in rows if r["axis"] == "slip"} == {0.4}
    assert all(r["level"] is None for r in rows if r["axis"] == "profile")
    figs = sorted(p.name for p in (out / "figures").glob("sweep_*.png"))
    assert figs == ["sweep_lidar_dropout.png", "sweep_profiles.png", "sweep_slip.png"]
    assert all((out / "figures" / f).stat().st_size > 20_000 for f in figs)
    page = (out / "sweep.md").read_text()
    assert "### wheel slip ratio" in page and "| DWA III (2,1,1) | given |" in page


def test_resume_runs_only_missing_episodes(one_second_world, tmp_path, monkeypatch):
    settings = tiny_settings(one_second_world, methods=("dwa1",))
    jobs = sweep_jobs(settings)
    # "Interrupted" after two episodes: a run over a prefix of the job list.
    evaluate(jobs[:2], tmp_path, progress=False, fields=SWEEP_FIELDS)
    before = (tmp_path / "results.csv").read_text()
    ran = []
    real = evaluation.run_job
    monkeypatch.setattr(
        evaluation, "run_job", lambda job, cfg: ran.append(job.key) or real(job, cfg)
    )
    rows, complete = run_sweep(settings, tmp_path, progress=False, figures=False)
    assert complete and len(rows) == len(jobs) == 4
    assert sorted(ran) == sorted(j.key for j in jobs[2:])  # nothing finished is recomputed
    assert (tmp_path / "results.csv").read_text().startswith(before)  # nothing finished is lost
    keys = [(r["world"], r["method"], r["seed"], r["noise"]) for r in read_sweep(tmp_path)]
    assert len(keys) == len(set(keys)) == 4


def test_a_row_cut_by_a_kill_is_dropped_and_rerun(one_second_world, tmp_path):
    settings = tiny_settings(one_second_world, methods=("dwa1",), axes=(), profiles=("none",))
    run_sweep(settings, tmp_path, progress=False, figures=False)
    path = tmp_path / "results.csv"
    full = path.read_text()
    path.write_text(full[: full.rindex("\n", 0, len(full) - 1) + 1] + "tiny,dwa1,0,no")
    rows, complete = run_sweep(settings, tmp_path, progress=False, figures=False)
    assert complete and len(rows) == 1 and path.read_text() == full


def children(pid: int) -> list[int]:
    """Child processes of pid (pool workers, multiprocessing's resource tracker)."""
    out = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            continue
    return out


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "workers"), [(signal.SIGKILL, 1), (signal.SIGTERM, 2)])
def test_killed_sweep_resumes_without_loss_or_duplicates(sig, workers, one_second_world, tmp_path):
    """A real kill mid-run, then the same command again. SIGKILL may cut a row in half;
    SIGTERM must also take the pool's worker processes down with the sweep."""
    argv = [sys.executable, "-m", "d3dwa_bullet.cli", "sweep", "--methods", "dwa1,dwa3",
            "--worlds", one_second_world, "--layouts", "0", "--levels", "2", "--seeds", "2",
            "--profiles", "none,real", "--out", str(tmp_path), "--workers", str(workers),
            "--json"]  # fmt: skip
    total = 2 * (2 * (8 + 1) + 1)  # noise-free baseline: deterministic, run once per layout
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    csv_path = tmp_path / "results.csv"
    workers_pids: list[int] = []
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        if csv_path.exists() and csv_path.read_text().count("\n") >= 6:
            break
        workers_pids = children(proc.pid)
        time.sleep(0.1)
    workers_pids = sorted(set(workers_pids) | set(children(proc.pid)))
    os.kill(proc.pid, sig)
    proc.wait(timeout=60)
    if sig == signal.SIGTERM:
        assert workers_pids
        deadline = time.monotonic() + 15
        while any(alive(c) for c in workers_pids) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not [c for c in workers_pids if alive(c)]
    n_before = len(read_sweep(tmp_path))
    assert 5 <= n_before < total
    assert subprocess.run(argv, capture_output=True).returncode == 0
    rows = read_sweep(tmp_path)
    keys = [(r["world"], r["method"], r["seed"], r["noise"]) for r in rows]
    assert len(keys) == len(set(keys)) == total


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--methods", "dwa9"], "unknown method 'dwa9'"),
        (["--methods", "dwa1", "--worlds", "R7"], "unknown world 'R7'"),
        (["--methods", "dwa1", "--styles", "R9-style"], "R9-style"),
        (["--methods", "dwa1", "--axes", "gravity"], "unknown noise axis"),
        (["--methods", "dwa1", "--profiles", "bogus"], "bogus"),
        (["--methods", "dwa1", "--levels", "0"], "--levels"),
    ],
)
def test_cli_sweep_bad_input_exits_2_with_one_line(extra, message, tmp_path, capsys):
    assert main(["sweep", "--out", str(tmp_path / "o"), "--layouts", "1", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("d3dwa: error:") and message in err and "\n" not in err
    assert not (tmp_path / "o" / "results.csv").exists()


def test_cli_sweep_refuses_an_eval_directory(one_second_world, tmp_path, capsys):
    out = str(tmp_path)
    assert main(["eval", "--methods", "dwa1", "--worlds", one_second_world, "--out", out,
                 "--workers", "1", "--json"]) == 0  # fmt: skip
    capsys.readouterr()
    args = ["sweep", "--methods", "dwa1", "--worlds", one_second_world, "--layouts", "0",
            "--out", out, "--workers", "1"]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "written by 'eval'" in err and "use another --out" in err


def test_cli_sweep_json_summary(one_second_world, tmp_path, capsys):
    args = ["sweep", "--methods", "dwa1", "--worlds", one_second_world, "--layouts", "0", "--levels",
            "1", "--axes", "lidar_range", "--profiles", "", "--seeds", "2", "--out",
            str(tmp_path), "--workers", "1", "--json"]  # fmt: skip
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] and out["episodes"] == 3  # the noise-free one once, not per seed
    points = [(s["axis"], s["x"], s["n"]) for s in out["summary"]]
    assert points == [("lidar_range", 0.0, 1), ("lidar_range", 0.1, 2)]
    assert all(np.isfinite(s["rate_lo"]) for s in out["summary"])
    assert all(s["time_mean"] is None or np.isfinite(s["time_mean"]) for s in out["summary"])


def test_the_sweep_page_scores_each_cell_and_marks_rows_from_before_the_score(
    tiny_sweep, one_second_world
):
    _, rows, _ = tiny_sweep
    settings = tiny_settings(one_second_world)
    page = sweep_markdown(rows, settings)
    assert f"Score ({SCORE_FORM}), mean [95 % interval]" in page and "BARN's official score" in page
    assert "; 0.00 |" in page  # one-second episodes: every one a timeout, every score 0
    assert "No score" not in page
    old = [r | {"score": None, "score_barn": None, "reference_length_m": None} for r in rows]
    unscored = sweep_markdown(old, settings)
    assert "No score: results from before the score" in unscored
    assert "; 0.00" not in unscored and f"Score ({SCORE_FORM}), mean" not in unscored


def test_generating_the_layouts_shows_a_bar_only_with_progress(capsys, monkeypatch):
    # the bar clears on close and redraws at most every 0.1 s: two fast layouts could finish unseen
    monkeypatch.setattr(sweep, "tqdm", functools.partial(tqdm, mininterval=0))
    settings = SweepSettings(
        methods=("dwa1",), worlds=(), styles=("R1-style", "R2-style"), layouts=1
    )
    assert len(sweep_worlds(settings, progress=True)) == 2
    assert "layouts" in (err := capsys.readouterr().err) and "2/2" in err
    sweep_worlds(settings)
    assert capsys.readouterr().err == ""


def test_a_sweep_refuses_another_episode_config_before_it_builds_layouts(
    one_second_world, tmp_path, monkeypatch
):
    settings = tiny_settings(one_second_world, methods=("dwa1",), axes=(), profiles=("none",))
    run_sweep(settings, tmp_path, progress=False, figures=False)
    before = (tmp_path / "results.csv").read_text()

    def no_jobs(*args, **kwargs):
        raise AssertionError("jobs built for a directory the sweep refuses")

    monkeypatch.setattr(sweep, "sweep_jobs", no_jobs)
    base = EpisodeConfig()
    other = replace(base, termination=replace(base.termination, time_limit=7.0))
    with pytest.raises(ResultsError, match=r"another episode config \(termination.time_limit"):
        run_sweep(settings, tmp_path, config=other, progress=False, figures=False)
    with pytest.raises(ResultsError, match="one directory holds one recovery setting"):
        run_sweep(
            settings,
            tmp_path,
            config=replace(base, recovery=recovery_params("nav2")),
            progress=False,
        )
    with pytest.raises(AssertionError, match="jobs built"):  # the same config resumes
        run_sweep(settings, tmp_path, config=base, progress=False)
    assert (tmp_path / "results.csv").read_text() == before
