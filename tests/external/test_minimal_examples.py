"""The two minimal methods of examples/minimal/ that docs/design/external-methods.md#write-one
walks through: a parameter chooser and a velocity planner, each run as a user runs it, by its
``module:Name`` with its folder on the import path."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.params import RobotLimits
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.world.registry import load_world
from tests.support.cli import run

MINIMAL = Path(__file__).resolve().parents[2] / "examples" / "minimal"
CHOOSER = "clearance_chooser:ClearanceChooser"
PLANNER = "go_to_goal:GoToGoal"


@pytest.fixture
def minimal_path(monkeypatch):
    monkeypatch.syspath_prepend(str(MINIMAL))  # as PYTHONPATH=examples/minimal does
    yield
    for module in ("clearance_chooser", "go_to_goal"):
        sys.modules.pop(module, None)


def test_the_page_finds_dwa_iii_where_the_action_set_has_it() -> None:
    # The page's worked example: DWA III's (2, 1, 1) at 4 s, horizon-major order.
    assert ACTIONS_FULL.encode((2, 1, 1, 4.0)) == 2 * 25 + 9 == 59
    assert ACTIONS_WEIGHTS_ONLY.encode((2, 1, 1, 4.0)) == 9
    assert tuple(ACTIONS_FULL.decode(59)) == (2.0, 1.0, 1.0, 4.0)
    assert [tuple(a)[:3] for a in ACTIONS_FULL.actions[:3]] == [(1, 1, 1), (1, 1, 2), (1, 1, 3)]
    assert ACTIONS_FULL.horizons == (2.0, 3.0, 4.0, 5.0)


def test_the_chooser_picks_dwa_iii_weights_at_the_horizons_it_names(minimal_path) -> None:
    result = run_episode(load_world("TS1"), make_controller(CHOOSER))
    assert result.outcome == "goal", result.summary()
    chosen = set(np.unique(result.log["action"]).tolist())
    assert chosen <= {9, 59, 84} and len(chosen) >= 2  # (2, 1, 1) at 2 s, 4 s and 5 s
    assert (result.log["wp"] == 2).all() and set(np.unique(result.log["tau"])) <= {2.0, 4.0, 5.0}


def test_the_planner_drives_to_the_goal_within_the_limits(minimal_path) -> None:
    result = run_episode(load_world("R1"), make_controller(PLANNER))
    limits = RobotLimits()
    assert result.outcome == "goal", result.summary()
    assert np.abs(result.log["v_cmd"]).max() <= limits.v_max
    assert np.abs(result.log["w_cmd"]).max() <= limits.w_max
    assert (result.log["action"] == -1).all()


def test_both_run_from_the_command_line(capsys, minimal_path, one_second_world) -> None:
    for name, kind in ((CHOOSER, "parameter chooser"), (PLANNER, "velocity planner")):
        code, out, err = run(capsys, "run", "--method", name, "--world", one_second_world)
        assert code == 0, err
        assert f"external {kind} from {name}" in out
