"""The compiled, pruned distance to the cylinders gives ``World.distance`` bit for bit
(docs/design/episode-cost.md), on BARN worlds, a shipped room, and no cylinders at all."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.episode_metrics import body_clearance
from d3dwa_bullet.world.barn import barn_world
from d3dwa_bullet.world.cylinder_distance import CylinderIndex, world_distance
from d3dwa_bullet.world.model import Box, World
from d3dwa_bullet.world.registry import load_world


@pytest.mark.parametrize(
    "world", [barn_world(0), barn_world(150), load_world("R3"), load_world("H3")]
)
def test_same_distances_as_the_world(world):
    rng = np.random.default_rng(1)
    xmin, ymin, xmax, ymax = world.bounds(0.5)
    points = np.column_stack((rng.uniform(xmin, xmax, 5000), rng.uniform(ymin, ymax, 5000)))
    assert np.array_equal(world_distance(world, points), world.distance(points))
    poses = np.column_stack((points[:400], rng.uniform(-np.pi, np.pi, 400)))
    fast = body_clearance(world, poses, distance=world_distance)
    assert np.array_equal(fast, body_clearance(world, poses))
    assert (fast < 0).any() and (fast > 0.2).any()  # overlaps and clear poses both met


def test_boxes_only_and_nothing():
    box = Box(center=(1.0, 0.0), size=(0.4, 0.2), yaw=0.3)
    world = World("boxes", "one box", (0.0, 0.0, 0.0), (2.0, 0.0), (box,))
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.5, 0.5]])
    assert np.array_equal(world_distance(world, points), world.distance(points))
    assert np.all(CylinderIndex(np.zeros((0, 2)), np.zeros(0)).nearest(points) == np.inf)
