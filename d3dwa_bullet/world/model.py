"""Worlds: static upright obstacles (boxes and cylinders), a start pose and a goal.

The obstacle maths every other module builds on: signed distance to an obstacle's footprint,
its axis-aligned extent and its outline polygon, and the check that a task's start leaves
the robot's body free and its goal outside every obstacle. How worlds are read from files
is in :mod:`~d3dwa_bullet.world.native` (the YAML format), :mod:`~d3dwa_bullet.world.sdf`,
:mod:`~d3dwa_bullet.world.map_server` and :mod:`~d3dwa_bullet.world.registry`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.geometry import body_outline, circle_polygon, rectangle_corners
from d3dwa_bullet.limits import MAX_TIME_LIMIT_S
from d3dwa_bullet.world.fields import vector

DEFAULT_HEIGHT = 0.5
"""Height of an obstacle whose file gives none, m."""
DISTANCE_BROADCAST = 2**15
"""Most point-cylinder pairs :meth:`World.distance` measures in one array operation; beyond
it, a loop over obstacles is faster (measured by ``tools/bench/bench_barn.py``)."""
CYLINDER_SEGMENTS = 48
"""Sides of the polygon that stands for a cylinder in :func:`obstacle_outline`."""


@dataclass(frozen=True)
class Box:
    """An upright box obstacle. center (x, y) m, size (sx, sy) m, yaw rad, height m."""

    center: tuple[float, float]
    size: tuple[float, float]
    yaw: float = 0.0
    height: float = DEFAULT_HEIGHT


@dataclass(frozen=True)
class Cylinder:
    """An upright cylinder obstacle. center (x, y) m, radius m, height m."""

    center: tuple[float, float]
    radius: float
    height: float = DEFAULT_HEIGHT


Obstacle = Box | Cylinder


@dataclass(frozen=True)
class World:
    """A navigation case: obstacles, start pose (x, y, yaw) and goal (x, y)."""

    name: str
    description: str
    start: tuple[float, float, float]
    goal: tuple[float, float]
    obstacles: tuple[Obstacle, ...] = ()
    group: str = "custom"
    time_limit: float | None = None
    source: str = "<memory>"
    """Where the world came from (a path, or a generator description)."""
    reference_length: float | None = None
    """Length of the task's published reference path, m (BARN's path files), or None: the
    episode score then takes the shortest collision-free route for the robot's footprint."""

    def with_task(
        self,
        start: tuple[float, float, float] | None = None,
        goal: tuple[float, float] | None = None,
        time_limit: float | None = None,
    ) -> World:
        """A copy with another start, goal or time limit, re-validated."""
        w = replace(
            self,
            start=self.start if start is None else vector(start, 3, self.source, "start"),  # type: ignore[arg-type]
            goal=self.goal if goal is None else vector(goal, 2, self.source, "goal"),  # type: ignore[arg-type]
            time_limit=self.time_limit if time_limit is None else float(time_limit),
        )
        validate_task(w)
        return w

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance from points to the nearest obstacle surface (negative inside).

        points: (N, 2) float64, m, world frame. Returns (N,) float64, m (+inf if no obstacles).
        A few points (a start, a goal, a route's waypoints) are measured against every
        cylinder in one array operation (a BARN world has hundreds); many points obstacle by
        obstacle, each already vectorised over the points. Both use the arithmetic of
        :func:`obstacle_distance`, so the result is the same bit for bit.
        """
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        best = np.full(len(pts), np.inf)
        centres, radii = self._cylinders
        if len(pts) * len(radii) > DISTANCE_BROADCAST:
            for ob in self.obstacles:
                best = np.minimum(best, obstacle_distance(ob, pts))
            return best
        if len(radii):
            d = pts[:, None, :] - centres[None]
            best = (np.hypot(d[..., 0], d[..., 1]) - radii).min(axis=1)
        for ob in self.obstacles:
            if isinstance(ob, Box):
                best = np.minimum(best, obstacle_distance(ob, pts))
        return best

    @cached_property
    def _cylinders(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres (M, 2) m and radii (M,) m of the world's cylinders, built once."""
        cyl = [ob for ob in self.obstacles if isinstance(ob, Cylinder)]
        centres = np.array([ob.center for ob in cyl], dtype=np.float64).reshape(-1, 2)
        return centres, np.array([ob.radius for ob in cyl], dtype=np.float64)

    def bounds(self, margin: float = 0.5) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) enclosing obstacles, start and goal, plus margin, m."""
        xs = [self.start[0], self.goal[0]]
        ys = [self.start[1], self.goal[1]]
        for ob in self.obstacles:
            ext = obstacle_extent(ob)
            xs += [ob.center[0] - ext[0], ob.center[0] + ext[0]]
            ys += [ob.center[1] - ext[1], ob.center[1] + ext[1]]
        return min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin


def obstacle_distance(ob: Obstacle, pts: np.ndarray) -> np.ndarray:
    """Signed distance (N,) from (N, 2) points to one obstacle's footprint, m."""
    d = pts - np.asarray(ob.center, dtype=np.float64)
    if isinstance(ob, Cylinder):
        return np.hypot(d[:, 0], d[:, 1]) - ob.radius
    c, s = math.cos(ob.yaw), math.sin(ob.yaw)
    local = np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]))
    q = np.abs(local) - 0.5 * np.asarray(ob.size, dtype=np.float64)
    outside = np.hypot(np.maximum(q[:, 0], 0.0), np.maximum(q[:, 1], 0.0))
    inside = np.minimum(np.maximum(q[:, 0], q[:, 1]), 0.0)
    return outside + inside


def obstacle_extent(ob: Obstacle) -> tuple[float, float]:
    """Half extents (x, y) of an obstacle's axis-aligned bounding box, m."""
    if isinstance(ob, Cylinder):
        return ob.radius, ob.radius
    c, s = abs(math.cos(ob.yaw)), abs(math.sin(ob.yaw))
    return (
        0.5 * (ob.size[0] * c + ob.size[1] * s),
        0.5 * (ob.size[0] * s + ob.size[1] * c),
    )


def obstacle_outline(ob: Obstacle, segments: int = CYLINDER_SEGMENTS) -> np.ndarray:
    """Counter-clockwise footprint polygon of an obstacle: (K, 2), m, world frame.

    A box gives its 4 corners, a cylinder a regular polygon of ``segments`` sides.
    """
    if isinstance(ob, Cylinder):
        return circle_polygon(ob.center, ob.radius, segments)
    return rectangle_corners(ob.center, ob.size, ob.yaw)


def validate_task(world: World) -> None:
    """Refuse a start pose in collision or a goal inside an obstacle."""
    if not all(math.isfinite(v) for v in (*world.start, *world.goal)):
        raise WorldFormatError(
            f"{world.source}: start {world.start} / goal {world.goal} must be finite"
        )
    if world.time_limit is not None and not world.time_limit > 0:
        raise WorldFormatError(
            f"{world.source}: field 'time_limit' must be > 0, got {world.time_limit!r}"
        )
    if world.time_limit is not None:
        MAX_TIME_LIMIT_S.check(
            f"{world.source}: field 'time_limit'", world.time_limit, "s", WorldFormatError
        )
    if start_in_collision(world, world.start):
        raise WorldFormatError(
            f"{world.source}: field 'start' = {list(world.start)} puts the robot body in collision"
        )
    if goal_in_obstacle(world, world.goal):
        raise WorldFormatError(
            f"{world.source}: field 'goal' = {list(world.goal)} lies inside an obstacle"
        )


def start_in_collision(world: World, start: tuple[float, float, float]) -> bool:
    """Would the robot body at start (x, y m, yaw rad) touch or overlap an obstacle?"""
    if not world.obstacles:
        return False
    body = body_outline(start)
    centre = world.distance(np.array([start[:2]]))  # the body's centre inside an obstacle
    return bool((world.distance(body) <= 0.0).any() or (centre <= 0.0).any())


def goal_in_obstacle(world: World, goal: tuple[float, float]) -> bool:
    """Does goal (x, y m) lie inside (or on) an obstacle?"""
    if not world.obstacles:
        return False
    return bool(float(world.distance(np.array([goal]))[0]) <= 0.0)
