"""tools/experiments/probe_route.py: episodes started part-way along a world's route."""

from __future__ import annotations

import json

import pytest
import yaml

from tools.experiments import probe_route

# 6 m straight ahead with 12 s to get there: too far from the start (>= 15 s at 0.4 m/s),
# reachable from 75 % of the way
SHORT_TIME_WORLD = {
    "name": "straight",
    "group": "custom",
    "description": "open floor, goal 6 m ahead, 12 s limit",
    "start": [0.0, 0.0, 0.0],
    "goal": [6.0, 0.0],
    "time_limit": 12.0,
    "obstacles": [{"type": "cylinder", "center": [3.0, 1.5], "radius": 0.2}],
}


def _script():
    return probe_route


@pytest.fixture
def straight(tmp_path) -> str:
    path = tmp_path / "straight.yaml"
    path.write_text(yaml.safe_dump(SHORT_TIME_WORLD))
    return str(path)


def test_a_later_start_reaches_a_goal_the_world_start_cannot(straight, capsys):
    assert _script().main([straight, "--methods", "dwa3", "--fractions", "0,0.75", "--json"]) == 0
    first, late = json.loads(capsys.readouterr().out)
    assert first["start"] == [0.0, 0.0, 0.0] and first["dwa3"]["outcome"] == "timeout"
    x, y, yaw = late["start"]
    assert x == pytest.approx(4.5, abs=0.05) and abs(y) < 0.05 and abs(yaw) < 0.05
    assert late["dwa3"]["outcome"] == "goal" and late["dwa3"]["time_s"] < 12.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--fractions", "0,1.0"], "route fraction"),
        (["--fractions", "0,half"], "--fractions"),
        (["--methods", "nope"], "unknown method"),
    ],
)
def test_bad_input_is_one_error_line(straight, capsys, args, message):
    assert _script().main([straight, *args]) == 2
    assert message in capsys.readouterr().err
