"""The global plan: a path on a costmap, replanned, and a carrot along it (docs/design/global-plan.md).

Pure maths (numpy, SciPy, scikit-image; no simulator). Beyond the paper and off by default
(``--global-plan none``); with it, every method alike drives toward the carrot instead of the
goal: the DWA's goal criterion and a learned policy's goal features read the carrot.

* ``scan``: Nav2's planner server on an obstacle layer built from the robot's own scans. The
  scans are remembered with the recovery layer's :class:`~d3dwa_bullet.planning.recovery.ScanMemory`
  (a lattice cell counts once at least MEMORY_HITS returns fell in it) over one replanning
  period, and each replan marks what that memory holds, for good, on the costmap (marking
  only, no clearing: the worlds are static). Unknown cells are free (Nav2's defaults).
* ``map``: the same planner on the world's known map (a static layer only): a privileged
  reference no robot without a map has.

The path (:mod:`~d3dwa_bullet.planning.costmap`) runs from the estimated pose to the goal; it is
replanned every ``replan_period`` seconds (Nav2's default tree: 1 Hz) and, with ``scan``, at once
when a return of the present scan lies on the path ahead (closer than r + m less a cell). The
carrot is ``lookahead`` metres along the path from its point nearest the robot (the goal once
less remains), or with the ``sight`` rule the end of the stretch of it the robot sees in a
straight line on the costmap (:mod:`~d3dwa_bullet.planning.carrot`). No path, a goal inside an
obstacle (its cell lethal) or a robot outside the costmap: the status says so, the episode logs
it, and the carrot is the goal itself (the local planner falls back to the goal direction, as
without a plan).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.geometry import wrap_angle
from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.carrot import carrot_point
from d3dwa_bullet.planning.costmap import (
    RESOLUTION,
    cell_costs,
    cell_of,
    cells_to_points,
    free_start,
    occupancy_distance,
    shortest_path,
)
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams
from d3dwa_bullet.planning.recovery import Pose, ScanMemory, to_world
from d3dwa_bullet.timing import perf
from d3dwa_bullet.world.grid import Grid, clearance_field
from d3dwa_bullet.world.model import World

STATUSES = ("ok", "no_path", "goal_blocked", "outside")
"""A plan's status; its 0-based index is the ``plan_status`` code in an episode's log."""
MEMORY_REACH = 1e6
"""Every remembered point is marked, however far, m."""


def scan_frame(start: tuple[float, ...], goal: tuple[float, ...], margin: float) -> Grid:
    """An empty scan costmap (all False: nothing occupied) covering start and goal + margin."""
    lo = np.floor((np.minimum(start[:2], goal[:2]) - margin) / RESOLUTION).astype(int)
    hi = np.ceil((np.maximum(start[:2], goal[:2]) + margin) / RESOLUTION).astype(int)
    shape = (int(hi[1] - lo[1]) + 1, int(hi[0] - lo[0]) + 1)
    return Grid(np.zeros(shape, dtype=bool), (lo[0] * RESOLUTION, lo[1] * RESOLUTION), RESOLUTION)


class GlobalPlanner:
    """The global plan of one episode: call :meth:`update` once per control step.

    params: the recipe; planner: its r + m is the lethal distance; control_period: s; start,
    goal: (x, y[, yaw]) in the estimate's frame, m; known: the world's clearance field (m, a
    Grid at RESOLUTION) for ``map`` (None for ``scan``).
    """

    def __init__(
        self,
        params: GlobalPlanParams,
        planner: PlannerParams,
        control_period: float,
        start: tuple[float, ...],
        goal: tuple[float, ...],
        known: Grid | None = None,
    ) -> None:
        if params.kind == "map" and known is None:
            raise ConfigError("--global-plan map needs the world's map")
        self.params, self.goal = params, (float(goal[0]), float(goal[1]))
        self.lethal = planner.admissible_clearance
        if known is not None and params.kind == "map":
            self.frame = Grid(np.zeros(known.shape, dtype=bool), known.origin, known.resolution)
            self._static: np.ndarray | None = cell_costs(known.values, self.lethal)
        else:
            self.frame, self._static = scan_frame(start, goal, params.margin), None
        self.occupied = self.frame.values
        """(ny, nx) bool: the cells marked as obstacles so far (scan)."""
        self.memory = ScanMemory(int(round(params.replan_period / control_period)))
        self.path: np.ndarray | None = None
        """(K, 2) m: the last path found, from the estimated pose to the goal (None: none)."""
        self.status = "ok"
        self.paths: list[tuple[float, np.ndarray]] = []
        """(t, path (K, 2)) of every path found, for the figures."""
        self.events: list[tuple[float, str]] = []
        """(t, status) each time the status changed (the first replan included)."""
        self.replans = 0
        self.blocked_replans = 0
        self.codes: list[int] = []
        """The status code (status_code) after each update."""
        self.seconds = [0.0, 0.0]
        """[all updates, replans] wall-clock seconds spent, s."""
        self._next = -math.inf
        self._tree: cKDTree | None = None
        self._arc = np.zeros(0)
        self._lethal: np.ndarray | None = None
        """(ny, nx) bool: the lethal cells of the costmap the last path was planned on."""
        self._last: tuple[tuple[float, ...], tuple[tuple[float, float], float]] | None = None

    def update(self, t: float, pose: Pose, points: np.ndarray) -> tuple[float, float]:
        """The carrot (x, y) for this step: t (s), pose (estimated x, y, yaw), points (M, 2)
        valid returns in base_link."""
        t0 = perf()
        if self._static is None:
            self.memory.add(pose, points)
        blocked = self._static is None and self._blocked(pose, points)
        if t >= self._next - 1e-9 or blocked:
            if blocked and t < self._next - 1e-9:
                self.blocked_replans += 1
            t1 = perf()
            self._replan(t, pose)
            self.seconds[1] += perf() - t1
            self._next = t + self.params.replan_period
        carrot = self.carrot(pose)[0]
        self.codes.append(status_code(self.status))
        self.seconds[0] += perf() - t0
        return carrot

    def carrot(self, pose: Pose) -> tuple[tuple[float, float], float]:
        """(carrot (x, y), path length left from the pose to the goal, m): by the params' carrot
        rule (:mod:`~d3dwa_bullet.planning.carrot`) on the last path and its costmap; the goal
        itself (and its straight distance) without a path."""
        if self.path is None or len(self.path) < 2:
            return self.goal, math.hypot(self.goal[0] - pose[0], self.goal[1] - pose[1])
        if self._last is not None and self._last[0] == tuple(pose[:2]):
            return self._last[1]
        point, left = carrot_point(
            self.params.carrot, self.path, self._arc, pose, self.params.lookahead,
            self._lethal, self.frame.origin, self.frame.resolution, self.lethal + RESOLUTION,
        )  # fmt: skip
        out = ((float(point[0]), float(point[1])), left)
        self._last = (tuple(pose[:2]), out)
        return out

    def observed_goal(self, pose: Pose, carrot: tuple[float, float]) -> tuple[float, float]:
        """The goal a policy's observation reads: the carrot, or (goal_distance ``path``) the
        point on the carrot's bearing at the path length left."""
        if self.params.goal_distance == "carrot":
            return carrot
        _, left = self.carrot(pose)
        dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
        norm = math.hypot(dx, dy)
        if norm < 1e-9:
            return carrot
        return (pose[0] + dx / norm * left, pose[1] + dy / norm * left)

    def _blocked(self, pose: Pose, points: np.ndarray) -> bool:
        """Does a return of the present scan lie on the path ahead of its point nearest the
        pose (closer than r + m less one cell, outside the robot's own r + m plus a cell)?"""
        if self._tree is None or not len(points):
            return False
        world = to_world(pose, points)
        near, index = self._tree.query(world, distance_upper_bound=self.lethal - RESOLUTION)
        assert self.path is not None
        k = int(np.argmin(np.hypot(self.path[:, 0] - pose[0], self.path[:, 1] - pose[1])))
        hit = np.isfinite(near) & (index >= k)
        if not hit.any():
            return False
        own = np.hypot(world[hit, 0] - pose[0], world[hit, 1] - pose[1]) > self.lethal + RESOLUTION
        return bool(own.any())

    def _replan(self, t: float, pose: Pose) -> None:
        self.replans += 1
        grid = self.frame
        if self._static is None:
            pts, _ = self.memory.merged(pose, MEMORY_REACH)
            cells = np.floor((pts - np.asarray(grid.origin)) / grid.resolution + 0.5).astype(int)
            ny, nx = grid.shape
            inside = (
                (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
            )
            self.occupied[cells[inside, 1], cells[inside, 0]] = True
            costs = cell_costs(occupancy_distance(self.occupied, grid.resolution), self.lethal)
        else:
            costs = self._static
        self._lethal = ~np.isfinite(costs)
        start, goal = cell_of(grid, pose[:2]), cell_of(grid, self.goal)
        path = None
        if start is None or goal is None:
            status = "outside"
        elif not np.isfinite(costs[goal]):
            status = "goal_blocked"
        else:
            costs = free_start(costs, start, int(math.ceil(self.lethal / grid.resolution)))
            cells = shortest_path(costs, start, goal)
            status = "ok" if cells is not None else "no_path"
            if cells is not None:
                path = cells_to_points(grid, cells)
                path[0], path[-1] = pose[:2], self.goal
        self._set_path(t, path)
        if status != self.status or not self.events:
            self.events.append((t, status))
        self.status = status

    def _set_path(self, t: float, path: np.ndarray | None) -> None:
        self.path, self._last = path, None
        if path is None:
            self._tree, self._arc = None, np.zeros(0)
            return
        self.paths.append((t, path))
        self._arc = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))))
        self._tree = cKDTree(path)


def status_code(status: str) -> int:
    """A status's code in an episode's ``plan_status`` log column (its index in STATUSES)."""
    return STATUSES.index(status)


def known_field(params: GlobalPlanParams | None, world: World | None) -> Grid | None:
    """The clearance field (m, a Grid at RESOLUTION) ``map`` plans on: world's, in its own frame
    (None for ``scan`` or no plan); ConfigError when ``map`` has no world to read."""
    if params is None or params.kind != "map":
        return None
    if world is None:
        raise ConfigError("--global-plan map needs the world's map")
    return clearance_field(world, RESOLUTION, params.margin)


def make_global_planner(config: Any, world: World) -> GlobalPlanner | None:
    """The global plan of an episode config (an EpisodeConfig; None on the paper's stack) on
    world: ``map`` plans on its clearance field, ``scan`` from start and goal only."""
    params = config.global_plan
    if params is None:
        return None
    known = known_field(params, world)
    period = config.sim.control_period
    return GlobalPlanner(params, config.planner, period, world.start, world.goal, known)


class FirstStepPlan:
    """The global plan of a run that learns its start at its first step (a bag replay, the live
    loop of ``d3dwa drive``): the very :class:`GlobalPlanner` an episode of the same config
    makes, built from the first estimated pose and the goal, and :func:`steer` on it.

    config: an EpisodeConfig (no plan on the paper's stack); known_map: the world ``map``
    plans on (its clearance field is computed here, before any step), in the estimate's frame
    unless :attr:`frame` says where the estimate's frame lies on it.
    """

    def __init__(self, config: Any, known_map: World | None = None) -> None:
        self.params: GlobalPlanParams | None = config.global_plan
        self.config = config
        self.known = known_field(self.params, known_map)
        self.plan: GlobalPlanner | None = None
        """The plan being followed (None before the first step, or on the paper's stack)."""
        self.frame: tuple[float, float, float] | None = None
        """(x, y m, turn rad): the estimate's frame on known_map's (a point p of the estimate's
        frame is at (x, y) + R(turn) p on the map); None: the same frame. The plan then runs
        on the map's frame and its carrot comes back to the estimate's."""

    def steer(
        self, t: float, pose: Any, points: np.ndarray, goal: Any
    ) -> tuple[tuple[float, float], tuple[float, float]]:
        """:func:`steer` at one step (t s, pose (3,) estimate, points (M, 2) base_link, goal
        (2,) m), after making the plan from pose and goal at the first."""
        pose = (float(pose[0]), float(pose[1]), float(pose[2]))
        target = (float(goal[0]), float(goal[1]))
        frame = self.frame
        if frame is not None:
            pose = (*moved(frame, pose), wrap_angle(pose[2] + frame[2]))
            target = moved(frame, target)
        if self.plan is None and self.params is not None:
            period = self.config.sim.control_period
            self.plan = GlobalPlanner(
                self.params, self.config.planner, period, pose, target, self.known
            )
        carrot, seen = steer(self.plan, t, pose, points, target)
        if frame is None:
            return carrot, seen
        back = inverse(frame)
        return moved(back, carrot), moved(back, seen)


def moved(frame: tuple[float, float, float], p: Any) -> tuple[float, float]:
    """Point p (x, y) of a frame at (x, y, turn) on another, in that other frame, m."""
    c, s = math.cos(frame[2]), math.sin(frame[2])
    return (frame[0] + c * p[0] - s * p[1], frame[1] + s * p[0] + c * p[1])


def inverse(frame: tuple[float, float, float]) -> tuple[float, float, float]:
    """The frame (x, y, turn) the other way round: moved(inverse(f), moved(f, p)) == p."""
    c, s = math.cos(frame[2]), math.sin(frame[2])
    return (-(c * frame[0] + s * frame[1]), s * frame[0] - c * frame[1], -frame[2])


def steer(
    plan: GlobalPlanner | None, t: float, pose: Pose, points: np.ndarray, goal: tuple[float, float]
) -> tuple[tuple[float, float], tuple[float, float]]:
    """(what the controller drives toward, what a policy's observation reads as the goal) at
    one control step: the goal twice without a plan, else the carrot and
    :meth:`GlobalPlanner.observed_goal`. t: s; pose: estimated; points: (M, 2) base_link."""
    if plan is None:
        return goal, goal
    carrot = plan.update(t, pose, points)
    return carrot, plan.observed_goal(pose, carrot)


def plan_log(plan: GlobalPlanner | None) -> dict[str, np.ndarray]:
    """The arrays an episode's log holds of its global plan (none without one):
    ``plan_status`` (one STATUSES code per observation), ``plan_path_t`` (P,) s when each
    path was found, ``plan_path_xy`` (sum K, 2) m all paths one after the other,
    ``plan_path_len`` (P,) points in each, ``plan_replans`` and ``plan_blocked_replans``
    counts, ``plan_seconds`` (2,) s spent in all updates and in replans."""
    if plan is None:
        return {}
    paths = [p for _, p in plan.paths]
    return {
        "plan_status": np.asarray(plan.codes, dtype=np.int8),
        "plan_path_t": np.asarray([t for t, _ in plan.paths], dtype=np.float64),
        "plan_path_xy": np.concatenate(paths) if paths else np.zeros((0, 2)),
        "plan_path_len": np.asarray([len(p) for p in paths], dtype=np.int64),
        "plan_replans": np.asarray(plan.replans),
        "plan_blocked_replans": np.asarray(plan.blocked_replans),
        "plan_seconds": np.asarray(plan.seconds),
    }


def logged_paths(log: dict[str, Any]) -> list[np.ndarray]:
    """Every path an episode's log holds, in the order found, each (K, 2) m (none without a
    global plan)."""
    lengths = log.get("plan_path_len")
    if lengths is None or not len(lengths):
        return []
    return np.split(np.asarray(log["plan_path_xy"]), np.cumsum(lengths)[:-1])
