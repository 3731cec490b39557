"""``d3dwa drive --lockstep`` against ``d3dwa serve --lockstep`` with a velocity planner from
outside the package is ``d3dwa run``: the same steps and commands, bit for bit; a planner
that answers beyond the limits mid-run, or takes longer than its budget (on a clock the test
moves by hand, realtime and lockstep), is refused in one line, and the robot stopped
(docs/design/external-methods.md#external-methods)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet import controllers  # noqa: E402
from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import EpisodeConfig, run_episode  # noqa: E402
from d3dwa_bullet.params import TerminationParams  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import refused, run  # noqa: E402
from tests.support.external_methods import CLOCK  # noqa: E402

FTG = Path(__file__).resolve().parents[2] / "examples" / "follow_the_gap"
NAME = "follow_the_gap.planner:FollowTheGap"
PATIENT = ("--lockstep", "--watchdog", "60", "--timeout", "30", "--speed-limit", "0.4,2.0")


@pytest.fixture
def ftg_path(monkeypatch):
    monkeypatch.syspath_prepend(str(FTG))
    yield
    for module in ("follow_the_gap.planner", "follow_the_gap"):
        sys.modules.pop(module, None)


def test_lockstep_drive_of_an_external_planner_is_its_run(capsys, serve, ftg_path):
    world = load_world("R3")
    sim, address = serve(world, mode="lockstep")
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", f"{world.goal[0]},{world.goal[1]}",
        "--method", NAME, "--json", *PATIENT,
    )  # fmt: skip
    assert code == 0, err
    live = json.loads(out)
    episode = run_episode(world, make_controller(NAME))
    assert live["outcome"] == episode.outcome == "goal" and live["steps"] == episode.steps
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )
    assert sim.received[-1] == (0.0, 0.0) and live["stop_acknowledged"]


def test_a_planner_beyond_the_limits_stops_the_robot(capsys, serve):
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0",
        "--method", "tests.support.external_methods:TooFast", *PATIENT,
    )  # fmt: skip
    assert "TooFast': command() returned (0.9, 0.0) at step 2: beyond the robot's limits" in line
    assert len(sim.received) == 3 and sim.received[-1] == (0.0, 0.0)  # two commands, the stop


@pytest.fixture
def manual_clock(monkeypatch):
    """Every controller ``drive`` builds times its method's calls on CLOCK."""

    def on_clock(*args, **kwargs):
        controller = make_controller(*args, **kwargs)
        controller.clock = CLOCK
        return controller

    monkeypatch.setattr(controllers, "make_controller", on_clock)


@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_a_call_over_its_budget_stops_the_robot(capsys, serve, manual_clock, mode):
    sim, address = serve(load_world("R1"), mode=mode)
    lockstep = PATIENT if mode == "lockstep" else PATIENT[1:]
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0",
        "--method", "tests.support.external_methods:OverBudget", *lockstep,
    )  # fmt: skip
    assert line == (
        "d3dwa: error: method 'tests.support.external_methods:OverBudget': command() took "
        "0.080 s at step 2, over its budget of 0.05 s (its budget_s); the robot was stopped "
        "after 3 commands"
    )
    # two of its commands, a zero command in place of the late one, then the stop
    assert [v > 0 for v, _ in sim.received[:2]] == [True, True]
    assert sim.received[2:] == [(0.0, 0.0), (0.0, 0.0)]


def test_the_same_method_within_its_budget_drives_as_it_runs(capsys, serve, manual_clock):
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", f"{world.goal[0]},{world.goal[1]}",
        "--method", "tests.support.external_methods:InBudget", "--json", "--time-limit", "2",
        *PATIENT,
    )  # fmt: skip
    assert code == 0, err
    live = json.loads(out)
    two_seconds = EpisodeConfig(termination=TerminationParams(time_limit=2.0))
    episode = run_episode(
        world, make_controller("tests.support.external_methods:InBudget"), config=two_seconds
    )
    assert live["outcome"] == episode.outcome == "timeout" and live["steps"] == episode.steps == 20
    np.testing.assert_array_equal(
        np.asarray(sim.received[:20]), np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )
    assert sim.received[20:] == [(0.0, 0.0)]  # only the stop at the end


def test_a_planner_that_exits_mid_run_stops_the_robot_and_is_refused(capsys, serve):
    sim, address = serve(load_world("R1"), mode="lockstep")
    line = refused(
        capsys, "drive", "--kachaka", address, "--goal", "3,0",
        "--method", "tests.support.external_methods:ExitsOnTenthCommand", *PATIENT,
    )  # fmt: skip
    assert "ExitsOnTenthCommand': command() raised at step 9: called sys.exit(0)" in line
    assert "robot was stopped" in line
    assert len(sim.received) >= 10 and sim.received[-1] == (0.0, 0.0)
