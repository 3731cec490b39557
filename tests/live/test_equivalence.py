"""``d3dwa drive`` against ``d3dwa serve --lockstep`` is ``d3dwa run``: same outcome, steps and
path, and the very same commands, bit for bit (docs/design/live.md#live).

The clamp is set to the simulator's own limits (``--speed-limit 0.4,2.0``): with Kachaka's API
limits (0.3 m/s) the clamp would change the commands ``run`` sends, which is what it is for.
Deadlines and the watchdog are generous: a loaded test machine must not stop a run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import EpisodeConfig, run_episode  # noqa: E402
from d3dwa_bullet.evaluation.jobs import make_noise  # noqa: E402
from d3dwa_bullet.learning.agents.onnx_export import export_onnx  # noqa: E402
from d3dwa_bullet.params import recovery_params  # noqa: E402
from d3dwa_bullet.resources import policies_dir  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import run  # noqa: E402
from tests.support.held_policy import held_checkpoint  # noqa: E402

PATIENT = ("--lockstep", "--watchdog", "60", "--timeout", "30", "--speed-limit", "0.4,2.0")


def drive_json(capsys, address, goal, method, *extra) -> dict:
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", f"{goal[0]},{goal[1]}",
        "--method", method, "--json", *PATIENT, *extra,
    )  # fmt: skip
    assert code == 0, err
    return json.loads(out)


@pytest.mark.parametrize("method", ["dwa3", "d3dwa"])
def test_lockstep_drive_is_the_run_episode(capsys, serve, method):
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    live = drive_json(capsys, address, world.goal, method)
    episode = run_episode(world, make_controller(method))
    row = episode.summary()
    for key in ("outcome", "steps", "time_s", "tl_m", "pd_rad"):
        assert live[key] == row[key], key
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )
    assert sim.received[-1] == (0.0, 0.0) and live["stop_acknowledged"]  # the stop came last
    truth = np.asarray(sim.truth[: live["steps"] + 1])
    np.testing.assert_array_equal(truth[:, 0], episode.log["true_x"])


def test_noisy_lockstep_drive_sends_the_run_commands(capsys, serve):
    """With noise the robot's odometry is the EKF estimate: drive judges the goal on it,
    ``run`` on ground truth, so the two may end at different steps; every command both sent
    is the same."""
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep", noise=make_noise("real", 0))
    live = drive_json(capsys, address, world.goal, "dwa3")
    episode = run_episode(
        world, make_controller("dwa3"), noise=make_noise("real", 0), noise_name="real"
    )
    n = min(live["steps"], episode.steps)
    assert n > 100 and live["outcome"] == episode.outcome == "goal"
    sent = np.asarray(sim.received[:n])
    logged = np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))[:n]
    np.testing.assert_array_equal(sent, logged)


def test_default_clamp_holds_commands_to_kachaka_limits(capsys, serve):
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", "3,0", "--method", "dwa3", "--json",
        "--lockstep", "--watchdog", "60", "--timeout", "30", "--time-limit", "5",
    )  # fmt: skip
    assert code == 0, err
    sent = np.asarray(sim.received)
    assert np.abs(sent[:, 0]).max() <= 0.3 and np.abs(sent[:, 1]).max() <= 1.57
    assert np.isclose(np.abs(sent[:, 0]).max(), 0.3)  # the planner asked for more: clamped


def test_an_onnx_policy_drives_the_torch_episode(capsys, serve, tmp_path):
    """``drive --onnx`` (onnxruntime) against ``serve --lockstep`` is ``run`` with the
    checkpoint the file was exported from: the same steps and commands."""
    checkpoint = policies_dir() / "d3dwa" / "seed-0"
    onnx = export_onnx(checkpoint, tmp_path / "d3dwa.onnx").file
    world = load_world("R2")
    sim, address = serve(world, mode="lockstep")
    live = drive_json(
        capsys, address, world.goal, "d3dwa", "--onnx", str(onnx), "--time-limit", "20"
    )
    episode = run_episode(world.with_task(time_limit=20.0), make_controller("d3dwa", checkpoint))
    assert live["steps"] == episode.steps > 10 and live["outcome"] == episode.outcome
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )


def test_a_held_onnx_policy_drives_the_held_torch_episode(capsys, serve, tmp_path):
    """A policy trained with decision_steps 10 (docs/design/agent.md#decision-period), exported:
    ``drive --onnx`` holds each action for 10 control steps, as ``run`` with its checkpoint
    does, and sends the same commands; asked every step, it would have sent others."""
    checkpoint = held_checkpoint(tmp_path / "held", decision_steps=10)
    onnx = export_onnx(checkpoint, tmp_path / "held.onnx").file
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    live = drive_json(
        capsys, address, world.goal, "d3dwa", "--onnx", str(onnx), "--time-limit", "3"
    )
    task = world.with_task(time_limit=3.0)
    held = run_episode(task, make_controller("d3dwa", checkpoint))
    actions = held.log["action"]
    assert live["steps"] == held.steps == 30
    assert [actions[t] for t in range(30)] == [actions[t - t % 10] for t in range(30)]
    sent = np.asarray(sim.received[:30])
    np.testing.assert_array_equal(sent, np.column_stack((held.log["v_cmd"], held.log["w_cmd"])))
    every_step = make_controller("d3dwa", checkpoint)
    every_step.hold = 1
    unheld = run_episode(task, every_step)
    assert len(set(unheld.log["action"][:10])) > 1  # the policy changes its mind within a period
    assert not np.array_equal(sent, np.column_stack((unheld.log["v_cmd"], unheld.log["w_cmd"])))


def test_recovery_runs_on_the_episode_clock(capsys, serve):
    """With ``--recovery nav2`` the recovery layer sees the episode's own clock (k x 0.1 s, not
    the stamps' ns / 1e9, which differ in the last bit): on US1, where DWA III stalls and
    recovers, every command is ``run``'s."""
    world = load_world("US1")
    config = EpisodeConfig(recovery=recovery_params("nav2"))
    sim, address = serve(world, mode="lockstep")
    live = drive_json(capsys, address, world.goal, "dwa3", "--recovery", "nav2")
    episode = run_episode(world, make_controller("dwa3"), config=config)
    assert (episode.log["recovery"] > 0).sum() > 5  # it did recover
    assert live["steps"] == episode.steps and live["recovery"] == "nav2"
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )


def test_the_ekf_estimator_drives_on_wheel_odometry_and_imu(capsys, serve):
    """``--estimator ekf`` re-fuses the served wheel odometry and gyro (no pose fixes), as
    ``replay --estimator ekf``: not bit-exact with ``run``, but it reaches the goal."""
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    live = drive_json(capsys, address, world.goal, "dwa3", "--estimator", "ekf")
    assert live["outcome"] == "goal"
    true_end = np.asarray(sim.truth[live["steps"]][:2])
    assert np.hypot(*(true_end - np.asarray(world.goal))) < 0.2
