"""Route starts: begin a training episode part-way along a world's route to its goal.

A long training world is solved only by a sequence of good choices, and an exploring
agent that fails early never sees the states near the goal, nor the constrictions half
way (the reverse-curriculum idea of starting episodes closer to the goal). A route start
moves the robot to a random point of the world's shortest route, kept ``clearance`` away
from every obstacle so the whole body is free, facing along the route up to a random
heading error. The obstacles and the goal are the world's own; only the start changes,
and the evaluation always uses the world's own start.
"""

from __future__ import annotations

import math

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.routes import shortest_path

#: Obstacle distance of a route start's base_link, m. The body's farthest corner is
#: ~0.27 m from base_link (docs/design/planner.md#footprint), so the whole body starts clear of everything.
ROUTE_START_CLEARANCE = 0.30
#: Largest heading error of a route start against the route's direction, rad.
ROUTE_START_HEADING = 0.5


def route_polyline(world: World, clearance: float = ROUTE_START_CLEARANCE) -> np.ndarray:
    """Vertices (N, 2) of the shortest route from start to goal keeping ``clearance``.

    Raises WorldFormatError if no route keeps that clearance (e.g. a gap too narrow).
    """
    return shortest_path(world, inflation=clearance).points


def point_along(points: np.ndarray, s: float) -> tuple[np.ndarray, float]:
    """The point at arc length ``s`` along a polyline and the direction (rad) of its segment."""
    seg = np.diff(points, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    ends = np.cumsum(lengths)
    i = min(int(np.searchsorted(ends, s)), len(seg) - 1)
    before = ends[i] - lengths[i]
    t = 0.0 if lengths[i] == 0 else min(max((s - before) / lengths[i], 0.0), 1.0)
    return points[i] + t * seg[i], math.atan2(seg[i, 1], seg[i, 0])


def route_length(points: np.ndarray) -> float:
    """Length of a polyline, m."""
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


def route_pose(points: np.ndarray, fraction: float) -> tuple[float, float, float]:
    """(x, y, yaw) at ``fraction`` of the route's length, facing along the route."""
    if not 0.0 <= fraction < 1.0:
        raise ConfigError(f"route fraction must be in [0, 1), got {fraction!r}")
    p, direction = point_along(points, fraction * route_length(points))
    return float(p[0]), float(p[1]), direction


def route_start(
    world: World,
    points: np.ndarray,
    rng: np.random.Generator,
    span: float,
    heading_error: float = ROUTE_START_HEADING,
) -> World:
    """A copy of ``world`` starting at a uniform point of the first ``span`` of its route.

    points: the route (``route_polyline``); span: fraction of the route length in (0, 1).
    The heading is the route's direction plus a uniform error in +-heading_error.
    """
    if not 0.0 < span < 1.0:
        raise ConfigError(f"route_start: span must be in (0, 1), got {span!r}")
    x, y, direction = route_pose(points, float(rng.uniform(0.0, span)))
    yaw = direction + float(rng.uniform(-heading_error, heading_error))
    return world.with_task(start=(x, y, math.atan2(math.sin(yaw), math.cos(yaw))))
