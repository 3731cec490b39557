"""Route starts: a training episode may begin part-way along its world's route."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.world.registry import load_world
from d3dwa_bullet.world.route_start import (
    ROUTE_START_CLEARANCE,
    ROUTE_START_HEADING,
    point_along,
    route_polyline,
    route_start,
)


def _distance_to_polyline(points: np.ndarray, p: np.ndarray) -> tuple[float, float]:
    """(distance from p to the polyline, arc length of the nearest point)."""
    best, at, walked = math.inf, 0.0, 0.0
    for a, b in zip(points[:-1], points[1:], strict=True):
        ab = b - a
        n = float(np.hypot(*ab))
        t = min(max(float(np.dot(p - a, ab)) / (n * n), 0.0), 1.0)
        d = float(np.hypot(*(a + t * ab - p)))
        if d < best:
            best, at = d, walked + t * n
        walked += n
    return best, at


def test_point_along_an_l_shaped_polyline() -> None:
    pts = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]])
    p, heading = point_along(pts, 0.5)
    assert np.allclose(p, [0.5, 0.0]) and heading == pytest.approx(0.0)
    p, heading = point_along(pts, 2.5)
    assert np.allclose(p, [2.0, 0.5]) and heading == pytest.approx(math.pi / 2)
    p, _ = point_along(pts, 99.0)  # past the end: clamped to the last vertex
    assert np.allclose(p, [2.0, 1.0])


def test_route_starts_lie_on_the_route_clear_of_obstacles_and_keep_the_task() -> None:
    world = load_world("TS4")
    route = route_polyline(world)
    length = float(np.hypot(*np.diff(route, axis=0).T).sum())
    rng = np.random.default_rng(7)
    fractions = []
    for _ in range(40):
        w = route_start(world, route, rng, span=0.6)
        p = np.array(w.start[:2])
        off, s = _distance_to_polyline(route, p)
        assert off < 1e-9
        fractions.append(s / length)
        # the route keeps the whole body clear (a grid cell of slack)
        assert world.distance(p[None])[0] >= ROUTE_START_CLEARANCE - 0.02
        _, direction = point_along(route, s)
        err = math.atan2(math.sin(w.start[2] - direction), math.cos(w.start[2] - direction))
        assert abs(err) <= ROUTE_START_HEADING + 1e-9
        assert w.goal == world.goal and w.obstacles == world.obstacles and w.name == "TS4"
    assert max(fractions) <= 0.6 + 1e-9 and min(fractions) < 0.15 and max(fractions) > 0.45


@pytest.mark.parametrize("span", [0.0, 1.0, float("nan")])
def test_route_start_refuses_a_bad_span(span: float) -> None:
    world = load_world("TS1")
    with pytest.raises(ConfigError, match="span"):
        route_start(world, route_polyline(world), np.random.default_rng(0), span=span)


def test_env_route_starts_are_seeded_and_leave_the_other_draws_alone() -> None:
    plain = D3DWAEnv(worlds=("TS1", "TS4"))
    moved = D3DWAEnv(worlds=("TS1", "TS4"), route_start_prob=1.0, route_start_span=0.5)
    again = D3DWAEnv(worlds=("TS1", "TS4"), route_start_prob=1.0, route_start_span=0.5)
    try:
        for seed in range(4):
            _, info0 = plain.reset(seed=seed)
            obs1, info1 = moved.reset(seed=seed)
            obs2, _ = again.reset(seed=seed)
            assert info1["world"] == info0["world"] and info1["noise"] == info0["noise"]
            assert not info0["route_start"] and info1["route_start"]
            assert plain.world.start == load_world(info0["world"]).start
            assert moved.world.start != plain.world.start
            assert moved.world.start == again.world.start and np.array_equal(obs1, obs2)
    finally:
        for env in (plain, moved, again):
            env.close()


def test_env_never_route_starts_a_generated_layout_or_a_pinned_world() -> None:
    env = D3DWAEnv(worlds=("TS1",), generators=("R1-style",), generator_prob=0.5,
                   route_start_prob=1.0)  # fmt: skip
    try:
        kinds = set()
        for seed in range(8):
            _, info = env.reset(seed=seed)
            kinds.add(info["task"])
            assert info["route_start"] == (info["task"] == "TS1")
        assert kinds == {"TS1", "R1-style"}
        _, info = env.reset(seed=0, options={"world": "TS1"})
        assert not info["route_start"] and env.world.start == load_world("TS1").start
    finally:
        env.close()


def test_env_refuses_route_starts_in_a_world_without_a_clear_route(tmp_path) -> None:
    # a 0.5 m gap: passable for the planner (> 0.40 m) but no route keeps 0.30 m
    path = tmp_path / "slot.yaml"
    path.write_text(
        "name: slot\ngroup: train\ndescription: a wall with a 0.5 m slot\n"
        "start: [0.0, 0.0, 0.0]\ngoal: [3.0, 0.0]\nobstacles:\n"
        "  - {type: wall, start: [1.5, 0.25], end: [1.5, 3.0]}\n"
        "  - {type: wall, start: [1.5, -0.25], end: [1.5, -3.0]}\n"
        "  - {type: wall, start: [-1.0, 3.0], end: [4.0, 3.0]}\n"
        "  - {type: wall, start: [-1.0, -3.0], end: [4.0, -3.0]}\n"
        "  - {type: wall, start: [-1.0, -3.0], end: [-1.0, 3.0]}\n"
        "  - {type: wall, start: [4.0, -3.0], end: [4.0, 3.0]}\n"
    )
    D3DWAEnv(worlds=(str(path),)).close()  # fine without route starts
    with pytest.raises(ConfigError, match="route_start_prob > 0 needs a route keeping 0.3 m"):
        D3DWAEnv(worlds=(str(path),), route_start_prob=0.5)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"route_start_prob": 1.5}, "route_start_prob"),
        ({"route_start_prob": float("nan")}, "route_start_prob"),
        ({"route_start_span": 0.0}, "route_start_span"),
    ],
)
def test_env_refuses_bad_route_start_settings(kwargs: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        D3DWAEnv(worlds=("TS1",), **kwargs)
