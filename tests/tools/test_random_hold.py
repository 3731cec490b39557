"""tools.experiments.random_hold: the random reference at a decision period, bad input."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.world.registry import load_world
from tools.experiments import random_hold


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--recovery", "spin"], "spin"),
        (["--hold", "0"], "--hold"),
        (["--seeds", "a"], "--seeds"),
        (["--reference", "dwa3"], "--reference 'dwa3'"),
        (["--noise", "stormy"], "--noise 'stormy'"),
    ],
)
def test_bad_input_is_one_line_and_status_2(args: list[str], named: str, capsys) -> None:
    assert random_hold.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and named in err[0]


def test_one_layout_counts_goals_per_seed_with_the_recovery_named(monkeypatch, capsys) -> None:
    monkeypatch.setattr(random_hold, "layouts", lambda: [load_world("R2")])
    assert random_hold.main(["--hold", "10", "--seeds", "0,1", "--recovery", "nav2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["hold"] == 10 and out["recovery"] == "nav2" and out["layouts"] == 1
    assert set(out["goals"]) == {"0", "1"} and all(g in (0, 1) for g in out["goals"].values())
    assert out["success"] == sum(out["goals"].values()) / 2


def test_at_hold_1_it_is_the_reference_method_as_eval_runs_it(monkeypatch, capsys) -> None:
    """--hold 1 under a noise profile is the `random-weights` method's own episode."""
    world = load_world("R2")
    monkeypatch.setattr(random_hold, "layouts", lambda: [world])
    argv = ["--reference", "random-weights", "--noise", "real", "--seeds", "0,1", "--json"]
    assert random_hold.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reference"] == "random-weights" and out["noise"] == "real"
    for seed in (0, 1):
        controller = make_controller("random-weights")
        expected = run_episode(world, controller, seed, noise=make_noise("real", seed),
                               noise_name="real").outcome == "goal"  # fmt: skip
        assert out["goals"][str(seed)] == int(expected)
