"""``d3dwa drive --global-plan`` follows the carrot exactly as an episode does
(docs/design/global-plan.md#live-robot): against ``d3dwa serve --lockstep`` it is ``d3dwa run``
with the same plan, step for step; no path is said and driven through, never a crash.

Deadlines and the watchdog are generous and the clamp is the simulator's own (as in
test_equivalence.py): a loaded test machine must not stop a run.
"""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import EpisodeConfig, run_episode  # noqa: E402
from d3dwa_bullet.planning.global_plan import STATUSES  # noqa: E402
from d3dwa_bullet.planning.global_plan_params import global_plan_params  # noqa: E402
from d3dwa_bullet.world.map_server import load_map_world  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.support.cli import run  # noqa: E402

PATIENT = ("--lockstep", "--watchdog", "60", "--timeout", "30", "--speed-limit", "0.4,2.0")


def drive(capsys, address, goal, *extra) -> tuple[dict, str]:
    code, out, err = run(
        capsys, "drive", "--kachaka", address, "--goal", f"{goal[0]},{goal[1]}",
        "--method", "dwa3", "--json", *PATIENT, *extra,
    )  # fmt: skip
    assert code == 0, err
    return json.loads(out), err


def status_changes(codes: np.ndarray) -> list[list]:
    """[step, status] wherever an episode's plan_status log changes (the first step included)."""
    return [[k, STATUSES[c]] for k, c in enumerate(codes) if k == 0 or c != codes[k - 1]]


def assert_same_run(sim, live: dict, episode) -> None:
    """The live run is the episode: outcome, steps, the commands bit for bit, the true path."""
    row = episode.summary()
    for key in ("outcome", "steps", "time_s", "tl_m", "pd_rad"):
        assert live[key] == row[key], key
    sent = np.asarray(sim.received[: live["steps"]])
    np.testing.assert_array_equal(
        sent, np.column_stack((episode.log["v_cmd"], episode.log["w_cmd"]))
    )
    truth = np.asarray(sim.truth[: live["steps"] + 1])
    np.testing.assert_array_equal(
        truth[:, :2], np.column_stack((episode.log["true_x"], episode.log["true_y"]))
    )
    assert sim.received[-1] == (0.0, 0.0) and live["stop_acknowledged"]  # the stop came last


def test_drive_global_plan_scan_is_the_run_step_for_step(capsys, serve):
    """On US1 (a stall world without a plan) ``drive --global-plan scan`` sends ``run``'s
    commands, replans at the same steps, and ends the same way."""
    world = load_world("US1")
    sim, address = serve(world, mode="lockstep")
    live, _ = drive(capsys, address, world.goal, "--global-plan", "scan", "--time-limit", "20")
    config = EpisodeConfig(global_plan=global_plan_params("scan"))
    episode = run_episode(replace(world, time_limit=20.0), make_controller("dwa3"), config=config)
    assert live["global_plan"] == "scan" and live["steps"] > 50
    assert_same_run(sim, live, episode)
    changes = status_changes(episode.log["plan_status"][: live["steps"]])
    assert live["plan_events"] == changes and changes[0] == [0, "ok"]


def test_without_a_plan_the_carrot_is_not_followed(capsys, serve):
    """The plan changes what drive sends (the test above could not pass on the goal alone)."""
    world = load_world("US1")
    _, address = serve(world, mode="lockstep")
    live, _ = drive(capsys, address, world.goal, "--time-limit", "4")
    sim2, address2 = serve(world, mode="lockstep")
    planned, _ = drive(capsys, address2, world.goal, "--global-plan", "scan", "--time-limit", "4")
    assert "global_plan" not in live and "plan_events" not in live
    assert planned["tl_m"] != live["tl_m"] or planned["pd_rad"] != live["pd_rad"]
    assert len(sim2.received) == planned["steps"] + 1


def write_map(folder, *walls: tuple[float, float, float, float]) -> tuple:
    """A map_server map (YAML + PGM), 6 x 4 m at 0.05 m from origin (-1.5, -2), free but for
    the boxes (x0, x1, y0, y1), m; (its path, the world it loads as)."""
    res, origin = 0.05, (-1.5, -2.0)
    pixels = np.full((80, 120), 254, dtype=np.uint8)
    for wall in walls:
        c0, c1 = (int(round((x - origin[0]) / res)) for x in wall[:2])
        r0, r1 = (80 - int(round((y - origin[1]) / res)) for y in wall[3:1:-1])
        pixels[r0:r1, c0:c1] = 0
    cv2.imwrite(str(folder / "walls.pgm"), pixels)
    path = folder / "walls.yaml"
    path.write_text(
        "image: walls.pgm\nresolution: 0.05\norigin: [-1.5, -2.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return path, load_map_world(path)


def test_drive_global_plan_map_reads_the_map_file_as_run_reads_the_world(capsys, serve, tmp_path):
    """``--global-plan map --map FILE`` plans on the file's map: served as the world itself,
    the live run is ``run --global-plan map`` on that world, step for step."""
    path, world = write_map(tmp_path, (1.0, 1.3, -1.0, 0.8))
    task = world.with_task(goal=(2.8, 0.0))
    sim, address = serve(task, mode="lockstep")
    live, _ = drive(
        capsys, address, task.goal, "--global-plan", "map", "--map", path, "--time-limit", "25"
    )
    config = EpisodeConfig(global_plan=global_plan_params("map"))
    episode = run_episode(replace(task, time_limit=25.0), make_controller("dwa3"), config=config)
    assert live["global_plan"] == "map" and live["steps"] > 50
    assert live["plan_events"][0] == [0, "ok"]
    assert_same_run(sim, live, episode)


def test_a_goal_inside_an_obstacle_is_said_and_driven_toward(capsys, serve):
    """R1's goal moved into a box: the plan says goal_blocked at the first step, the robot
    drives toward the goal direction, the run ends as any run does, and the stop goes last."""
    world = load_world("R1")
    sim, address = serve(world, mode="lockstep")
    inside = (1.4, -0.62)  # the centre of R1's box of 0.35 m
    live, err = drive(capsys, address, inside, "--global-plan", "scan", "--time-limit", "2")
    assert live["plan_events"] == [[0, "goal_blocked"]] and live["outcome"] == "timeout"
    assert "step 0: global plan goal_blocked: the goal lies inside an obstacle" in err
    sent = np.asarray(sim.received)
    assert (sent[:-1, 0] > 0.1).sum() > 10  # it drove, toward the goal: 1.5 m became about 1
    assert sim.received[-1] == (0.0, 0.0) and live["stop_acknowledged"]


def test_no_path_on_the_map_is_said_and_driven_toward(capsys, serve, tmp_path):
    """A goal walled in on the map file: no_path from the first step, the goal direction
    driven, the stop last."""
    ring = [
        (2.4, 2.5, -0.5, 0.5),
        (3.1, 3.2, -0.5, 0.5),
        (2.4, 3.2, 0.4, 0.5),
        (2.4, 3.2, -0.5, -0.4),
    ]
    path, world = write_map(tmp_path, *ring)
    task = world.with_task(goal=(2.8, 0.0))
    sim, address = serve(task, mode="lockstep")
    live, err = drive(
        capsys, address, task.goal, "--global-plan", "map", "--map", path, "--time-limit", "2"
    )
    assert live["plan_events"] == [[0, "no_path"]] and live["outcome"] == "timeout"
    assert (
        "step 0: global plan no_path: no path on the costmap: driving toward the goal direction"
        in err
    )
    sent = np.asarray(sim.received)
    assert (sent[:-1, 0] > 0.1).sum() > 10 and sim.received[-1] == (0.0, 0.0)
