"""Shared fixtures: small worlds built in memory, and a quiet matplotlib."""

from __future__ import annotations

import matplotlib
import pytest

matplotlib.use("Agg")

from d3dwa_bullet.world import Box, Cylinder, World  # noqa: E402


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
