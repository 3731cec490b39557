"""Shared fixtures: small worlds built in memory or written to a file, a quiet matplotlib, and
property tests that draw the same examples on every run (unit tests stay deterministic)."""

from __future__ import annotations

import matplotlib
import pytest
import yaml
from hypothesis import settings

matplotlib.use("Agg")
settings.register_profile("deterministic", derandomize=True)
settings.load_profile("deterministic")

from d3dwa_bullet.world.model import Box, Cylinder, World  # noqa: E402


@pytest.fixture
def wall_world() -> World:
    """A wall whose near face is 1.95 m ahead of base_link; goal before it."""
    return World(
        "wall", "one wall ahead", (0.0, 0.0, 0.0), (1.0, 0.0), (Box((2.0, 0.0), (0.1, 4.0)),)
    )


@pytest.fixture
def open_world() -> World:
    """No obstacles at all; goal 1.5 m ahead."""
    return World("open", "empty floor", (0.0, 0.0, 0.0), (1.5, 0.0), ())


@pytest.fixture
def post_world() -> World:
    """A post straight on the line to the goal: the planner must go around it."""
    return World("post", "one post", (0.0, 0.0, 0.0), (2.5, 0.0), (Cylinder((1.2, 0.0), 0.15),))


ONE_SECOND_WORLD = {
    "name": "tiny",
    "group": "custom",
    "description": "a post beside the way",
    "start": [0.0, 0.0, 0.0],
    "goal": [1.6, 0.0],
    "time_limit": 1.0,
    "obstacles": [{"type": "cylinder", "center": [0.8, 0.35], "radius": 0.1}],
}


@pytest.fixture(scope="module")
def one_second_world(tmp_path_factory) -> str:
    """Path of a world file whose episodes stop after 1 s (10 steps): cheap episodes for
    the evaluation, sweep and report machinery, not for judging navigation."""
    path = tmp_path_factory.mktemp("worlds") / "tiny.yaml"
    path.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    return str(path)
