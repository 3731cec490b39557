"""tools.experiments.random_hold: the random reference at a decision period, bad input."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.world.registry import load_world
from tools.experiments import random_hold


@pytest.mark.parametrize(
    ("args", "named"),
    [(["--recovery", "spin"], "spin"), (["--hold", "0"], "--hold"), (["--seeds", "a"], "--seeds")],
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
