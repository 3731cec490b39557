"""``d3dwa drive --method random`` draws from episode seed 0, its warm-up draw undone: against
``d3dwa serve --lockstep`` it sends the commands of ``run_episode(..., seed=0)``, bit for bit."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import run_episode  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import run  # noqa: E402


def test_lockstep_drive_with_random_is_the_run_episode_of_seed_0(capsys, serve):
    world = load_world("R1").with_task(time_limit=3.0)
    sim, address = serve(world, mode="lockstep")
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", f"{world.goal[0]},{world.goal[1]}",
        "--method", "random", "--json", "--lockstep", "--watchdog", "60", "--timeout", "30",
        "--speed-limit", "0.4,2.0", "--time-limit", "3",
    )  # fmt: skip
    assert code == 0, err
    live = json.loads(out)
    episode = run_episode(world, make_controller("random"), seed=0)
    assert live["steps"] == episode.steps == 30
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )
