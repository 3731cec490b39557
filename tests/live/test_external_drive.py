"""``d3dwa drive --lockstep`` against ``d3dwa serve --lockstep`` with a velocity planner from
outside the package is ``d3dwa run``: the same steps and commands, bit for bit; a planner
that answers beyond the limits mid-run is refused in one line, and the robot stopped
(docs/design.md#external-methods)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import run_episode  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import refused, run  # noqa: E402

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
