"""The action-set probes: geodesic route field, the oracle and the script."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.geometry import arc_step
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.planning.observation import goal_in_body
from d3dwa_bullet.planning.planner import plan
from d3dwa_bullet.world.model import Box, World
from d3dwa_bullet.world.routes import geodesic_field
from tools.experiments import probe_actions
from tools.experiments.oracle import ORACLE, fixed_action_outcome, oracle_choice, run_oracle


def _at(field, x, y) -> float:
    i, j = field.cell_of(np.array([[x, y]]))[0]
    return float(field.values[i, j])


def test_geodesic_field_is_the_straight_distance_in_the_open(open_world):
    route = geodesic_field(open_world)
    assert _at(route, 1.5, 0.0) == 0.0
    assert _at(route, 0.0, 0.0) == pytest.approx(1.5, abs=1e-9)  # along a grid axis: exact
    # off-axis, the 8-connected grid overestimates by at most 1 - cos(22.5 deg) ~ 8 %
    d = _at(route, 0.0, 1.0)
    assert math.hypot(1.5, 1.0) <= d <= 1.09 * math.hypot(1.5, 1.0)


def test_geodesic_field_goes_round_a_wall_and_marks_it_blocked():
    # a 2 m wall across the straight line: the route must pass one of its ends
    world = World("w", "wall", (0.0, 0.0, 0.0), (2.0, 0.0), (Box((1.0, 0.0), (0.1, 2.0)),))
    route = geodesic_field(world)
    around = 2 * math.hypot(1.0, 1.0 + 0.2)  # via an end inflated by r + m = 0.20 m
    assert _at(route, 0.0, 0.0) >= around - 0.05
    assert _at(route, 0.0, 0.0) > 2.0 + 0.5
    assert math.isinf(_at(route, 1.0, 0.0))  # inside the inflated wall


def test_oracle_prefers_the_action_heading_round_the_wall_not_into_it():
    world = World("w", "wall", (0.0, 0.0, 0.0), (3.0, 0.0), (Box((1.5, 0.0), (0.1, 3.0)),))
    route = geodesic_field(world)
    # robot at 0.9 m from the wall's face, facing the goal; its scan sees the wall.
    ys = np.linspace(-1.5, 1.5, 151)
    points = np.column_stack((np.full_like(ys, 1.45 - 0.5), ys))
    config = EpisodeConfig()
    index = oracle_choice((0.5, 0.0, 0.0), (0.2, 0.0), points, world.goal, ACTIONS_FULL,
                          route, config)  # fmt: skip
    assert 0 <= index < len(ACTIONS_FULL)
    # the chosen command's arc end is no farther along the route than any other action's
    gb = goal_in_body((0.5, 0.0, 0.0), world.goal)
    plans = [plan((0.2, 0.0), points, gb, a, config.planner) for a in ACTIONS_FULL.actions]
    ends = [arc_step(0.5, 0.0, 0.0, p.v, p.w, a.tau)[:2]
            for p, a in zip(plans, ACTIONS_FULL.actions, strict=True)]  # fmt: skip
    cells = route.cell_of(np.asarray(ends))
    remaining = route.values[cells[:, 0], cells[:, 1]]
    assert remaining[index] == remaining.min()
    assert remaining[index] < _at(route, 0.5, 0.0)  # it makes progress along the route


def test_oracle_reaches_an_open_goal(open_world):
    result = run_oracle(open_world, ACTIONS_WEIGHTS_ONLY)
    assert result.outcome == "goal"
    assert result.method == ORACLE
    assert result.tl_m == pytest.approx(1.4, abs=0.05)  # straight on to the 0.1 m tolerance


def test_fixed_action_episode_is_that_action_at_every_step(open_world):
    result = fixed_action_outcome(open_world, ACTIONS_FULL, 7)
    assert result.outcome == "goal" and result.method == "a7"
    wp, wc, ws, tau = ACTIONS_FULL.decode(7)
    assert result.steps > 0
    for name, value in (("wp", wp), ("wc", wc), ("ws", ws), ("tau", tau)):
        assert np.all(result.log[name] == value), name


def _script():
    return probe_actions


def test_probe_script_counts_fixed_actions_and_the_oracle(one_second_world, capsys):
    # a 1 s episode cannot cover the 1.6 m to the goal: every probe times out
    assert _script().main([one_second_world, "--actions", "weights", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["fixed_total"] == 25
    assert row["fixed_goal"] == 0 and row["fastest_fixed"] is None
    assert row["fixed_collision"] == 0
    assert row["oracle"] == "timeout" and row["oracle_time_s"] is None
    x, y = row["oracle_final_xy"]
    assert 0.0 < x < 0.5 and abs(y) < 0.2  # 10 steps of at most 0.04 m from the start


def test_probe_script_reports_an_oracle_that_reaches_the_goal(tmp_path, capsys):
    # an open floor with the goal 1 m ahead: every probe has time to get there
    world = {"name": "open1", "group": "custom", "description": "empty floor",
             "start": [0.0, 0.0, 0.0], "goal": [1.0, 0.0], "time_limit": 20.0, "obstacles": []}  # fmt: skip
    path = tmp_path / "open1.yaml"
    path.write_text(yaml.safe_dump(world))
    assert _script().main([str(path), "--actions", "weights", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["world"] == str(path)
    assert row["oracle"] == "goal"
    assert 0.0 < row["oracle_time_s"] < 20.0
    x, y = row["oracle_final_xy"]
    assert math.hypot(x - 1.0, y) < 0.2  # stopped at the goal, within its tolerance
    assert row["fixed_collision"] == 0 and 0 < row["fixed_goal"] <= row["fixed_total"] == 25
    fastest = row["fastest_fixed"]
    assert fastest is not None and fastest["action"] in row["fixed_reaching"]
    assert 0.0 < fastest["time_s"] < 20.0


def test_probe_script_rejects_an_unknown_world(capsys):
    assert _script().main(["NOWHERE", "--no-fixed"]) == 2
    assert "NOWHERE" in capsys.readouterr().err
