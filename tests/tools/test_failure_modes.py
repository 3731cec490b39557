"""The failure-mode table of a results directory, from its rows and logs."""

from __future__ import annotations

import json

from tests.evaluation.test_failures import log
from tests.support.results_logs import write_results
from tools.experiments.failure_modes import failure_records, main

CIRCLE = dict(world="V", method="d3dwa", seed=0, noise="harsh")


def results_dir(tmp_path):
    rows = [
        dict(world="W", method="d3dwa", policy_seed=0, seed=0, noise="harsh", outcome="timeout"),
        dict(world="W", method="d3dwa", policy_seed=1, seed=0, noise="harsh", outcome="goal"),
        dict(world="W", method="dwa3", policy_seed="", seed=0, noise="harsh", outcome="collision"),
        # 1.05 rad/s on average, a circle every 6 s; the second turns as fast but arrives
        dict(CIRCLE, policy_seed=0, outcome="timeout", pd_rad=21.0, time_s=20.0),
        dict(CIRCLE, policy_seed=1, outcome="goal", pd_rad=30.0, time_s=10.0),
    ]
    episodes = ((r, log(speed=0.0, outcome=r["outcome"])) for r in rows)
    return write_results(tmp_path, episodes, sweep=False)


def test_failures_are_counted_by_mode_per_noise_and_method(tmp_path, capsys):
    out = results_dir(tmp_path)
    records = {r["method"]: r for r in failure_records(out)}
    assert records["d3dwa"]["episodes"] == 4 and records["d3dwa"]["failures"] == 2
    assert records["d3dwa"]["modes"]["stall"] == 2 and records["d3dwa"]["symptoms"]["stall"] == 2
    assert records["d3dwa"]["circling"] == 1 and records["dwa3"]["circling"] == 0
    assert records["dwa3"]["modes"]["collision"] == 1
    assert records["d3dwa"]["symptoms_in_goals"]["stall"] == 2  # the successes stalled too
    assert main([str(out), "--json", "--figure", str(tmp_path / "modes.png")]) == 0
    assert json.loads(capsys.readouterr().out)[0]["noise"] == "harsh"
    assert (tmp_path / "modes.png").read_bytes()[:4] == b"\x89PNG"


def test_a_missing_log_is_named(tmp_path, capsys):
    out = results_dir(tmp_path)
    next((out / "logs").glob("W__d3dwa__p0*")).unlink()
    assert main([str(out)]) == 2
    assert "W__d3dwa__p0__harsh__s0.npz: log of the episode is missing" in capsys.readouterr().err


def test_logged_only_classifies_the_episodes_with_a_log_and_counts_the_rest(tmp_path, capsys):
    out = results_dir(tmp_path)
    for name in ("W__d3dwa__p0*", "W__dwa3*"):  # a d3dwa failure, and dwa3's only episode
        next((out / "logs").glob(name)).unlink()
    assert main([str(out)]) == 2
    assert "(2 of 5 episodes have none; --logged-only" in capsys.readouterr().err
    records = {r["method"]: r for r in failure_records(out, logged_only=True)}
    assert set(records) == {"d3dwa"}  # dwa3 has no logged episode: no record
    assert records["d3dwa"]["episodes"] == 3 and records["d3dwa"]["failures"] == 1
    assert records["d3dwa"]["unlogged"] == 1
    assert main([str(out), "--logged-only"]) == 0
    printed = capsys.readouterr().out
    assert "without a per-step log: 2 episodes" in printed and "DWA III" not in printed


def test_logged_only_refuses_a_directory_without_any_log(tmp_path, capsys):
    out = results_dir(tmp_path)
    for path in (out / "logs").glob("*.npz"):
        path.unlink()
    assert main([str(out), "--logged-only"]) == 2
    err = capsys.readouterr().err
    assert "log of the episode is missing (5 of 5 episodes have none)" in err
    assert len(err.strip().splitlines()) == 1
