"""The recovery layer around any controller: a progress checker and recovery behaviours.

Pure maths (numpy, no simulator): the episode loop, the Gymnasium env, the bag recorder and a
live driver feed it the same things they feed the planner (the estimated pose and velocity,
the valid scan points in base_link, the goal) and, while it recovers, drive its command
instead of the planner's. Off by default: the paper's stack has no such layer
(docs/design/recovery.md#recovery says what is kept from Nav2, what changed and why).

* Progress (Nav2's SimpleProgressChecker): the robot must leave a circle of ``radius`` about
  the pose where it last made progress within ``window`` seconds, judged on the *estimated*
  pose, as a robot would.
* Behaviours (``spin``, ``back_up``), one per failed check, round robin; after
  ``max_recoveries`` the layer gives up and the episode runs out. A behaviour ends with the
  robot stopped: it hands back at rest, as Nav2's do.
* Safety: a motion is admissible like a planner sample: every footprint circle centre along
  it stays farther than r + m from every point the robot has seen, now *or* in the last
  ``memory`` seconds (points carried along by the estimated pose, since Kachaka's 240 deg
  lidar sees nothing behind it), and every place the footprint sweeps was inside the body or
  in a remembered scan's field of view. The next ``lookahead`` seconds of the motion are
  checked before a behaviour starts and again at every step; a behaviour stops where they
  are no longer admissible (Nav2's spin and back-up do the same).
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import RECOVERY_BEHAVIOURS, PlannerParams, RecoveryParams

Pose = tuple[float, float, float]

RING = 8
"""Points on each footprint circle's r + m ring that must have been seen, besides its centre."""
MOTION_STEP = 0.05
"""Spacing of the footprint poses along a recovery motion, m (or rad for a spin)."""
SEEN_RANGE = 3.5
"""A remembered scan vouches for places up to this far from the lidar, m (d_max)."""
MEMORY_CELL = 0.02
"""Remembered points are merged on a lattice of this cell, m (the planner's resolution)."""
CLEARANCE_TOLERANCE = 1e-6
"""A motion that keeps the clearance the robot has now, to rounding, is not getting closer, m."""
REST = (0.02, 0.1)
"""(|v| m/s, |w| rad/s) of the estimate below which the robot counts as at rest: a behaviour
hands back only then (Nav2's behaviours end with a zero twist). Handed back turning at
1 rad/s, the planner's dynamic window (+-0.3 rad/s a step) holds no way to stop, and under
`harsh` its fallback then kept spinning and drove into an obstacle (docs/design/recovery.md#recovery)."""
BRAKE_LIMIT = 1.0
"""A stop that the estimate has not confirmed after this long hands back anyway, s (at
3 rad/s^2 a 1 rad/s turn stops in 0.33 s; the rest is latency and estimator lag)."""
MEMORY_HITS = 2
"""A remembered cell counts as an obstacle once this many returns fell in it: a surface is
hit by several beams (0.5 deg apart: 9 mm at 1 m) and by every scan that sees it, a spurious
return by one; a spurious point carried along for 30 s would otherwise block every motion."""


class RecoveryCommand(NamedTuple):
    """What the recovery layer drives this control step instead of the planner."""

    v: float
    """m/s (negative backs up)."""
    w: float
    """rad/s."""
    behaviour: str
    """A RECOVERY_BEHAVIOURS name."""

    @property
    def code(self) -> int:
        """1-based index in RECOVERY_BEHAVIOURS (0 in a log means no recovery)."""
        return RECOVERY_BEHAVIOURS.index(self.behaviour) + 1


class ProgressChecker:
    """Nav2's SimpleProgressChecker on the estimated pose: ``stuck`` once the robot has
    stayed within ``radius`` of its baseline pose for longer than ``window``."""

    def __init__(self, radius: float, window: float) -> None:
        self.radius, self.window = radius, window
        self.baseline: tuple[float, float] | None = None
        self.since = 0.0

    def reset(self, t: float, pose: Pose) -> None:
        self.baseline, self.since = (pose[0], pose[1]), t

    def stuck(self, t: float, pose: Pose) -> bool:
        """Update with the pose at time t (s); True when the window ran out without progress."""
        if (
            self.baseline is None
            or math.hypot(pose[0] - self.baseline[0], pose[1] - self.baseline[1]) > self.radius
        ):
            self.reset(t, pose)
            return False
        return t - self.since > self.window


def to_world(pose: Pose, points: np.ndarray) -> np.ndarray:
    """(M, 2) body-frame points -> the frame of pose (x, y, yaw)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + np.array(pose[:2])


def to_body(pose: Pose, points: np.ndarray) -> np.ndarray:
    """(M, 2) points in the frame of pose -> base_link at pose."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return (points - np.array(pose[:2])) @ np.array([[c, -s], [s, c]])


_NO_POINTS = np.zeros((0, 2))


class ScanMemory:
    """The scans of the last ``steps`` control steps with the estimated pose each was seen
    from: what lets a motion be checked toward where the lidar cannot see now."""

    def __init__(self, steps: int) -> None:
        self.scans: deque[tuple[Pose, np.ndarray]] = deque(maxlen=max(1, steps))

    def add(self, pose: Pose, points: np.ndarray) -> None:
        self.scans.append((pose, points))

    def merged(self, near: Pose, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """(points (M, 2), poses (P, 3)) in the estimate's frame: the lattice cells within
        ``reach`` of pose ``near`` hit by at least MEMORY_HITS returns, and the pose of every
        remembered scan."""
        if not self.scans:
            return np.zeros((0, 2)), np.zeros((0, 3))
        poses = np.array([p for p, _ in self.scans], dtype=np.float64)
        pts = np.concatenate([to_world(p, q) for p, q in self.scans if len(q)] or [_NO_POINTS])
        pts = pts[np.hypot(pts[:, 0] - near[0], pts[:, 1] - near[1]) <= reach]
        if not len(pts):
            return pts, poses
        cells = np.floor(pts / MEMORY_CELL + 0.5).astype(np.int64)
        # one int64 key per cell, so the counting is a 1-d unique (a 2-d one is ~30x slower)
        lo = cells.min(axis=0)
        span = int(cells[:, 1].max() - lo[1]) + 1
        keys, hits = np.unique(
            (cells[:, 0] - lo[0]) * span + cells[:, 1] - lo[1], return_counts=True
        )
        kept = keys[hits >= MEMORY_HITS]
        cells = np.column_stack((kept // span + lo[0], kept % span + lo[1]))
        return cells * MEMORY_CELL, poses


def motion_poses(behaviour: str, amount: float, direction: float) -> np.ndarray:
    """(N, 3) body-frame poses along a motion from the current pose (excluded) to its end:
    a spin of ``amount`` rad, or a back-up of ``amount`` m; direction +1 / -1 (spin sense)."""
    n = max(1, math.ceil(amount / MOTION_STEP))
    k = np.linspace(amount / n, amount, n)
    poses = np.zeros((n, 3))
    if behaviour == "spin":
        poses[:, 2] = direction * k
    else:
        poses[:, 0] = -k
    return poses


def circle_centres(poses: np.ndarray, centers_x: tuple[float, ...]) -> np.ndarray:
    """(N * C, 2) footprint circle centres at body-frame poses (N, 3)."""
    cx = np.asarray(centers_x)
    x = poses[:, :1] + np.cos(poses[:, 2:3]) * cx
    y = poses[:, 1:2] + np.sin(poses[:, 2:3]) * cx
    return np.column_stack((x.ravel(), y.ravel()))


def seen(
    places: np.ndarray,
    scan_poses: np.ndarray,
    lidar_x: float,
    fov: float,
    body: np.ndarray,
    radius: float,
) -> np.ndarray:
    """(Q,) bool: each place (Q, 2) lies inside the body's own circles (body: (C, 2) centres,
    radius r) or within SEEN_RANGE and the field of view of a remembered scan (scan poses
    (P, 3), all in one frame; lidar_x: the lidar's offset along the body axis)."""
    inside = (np.hypot(*(places[:, None, :] - body[None, :, :]).transpose(2, 0, 1)) <= radius).any(
        1
    )
    if not len(scan_poses):
        return inside
    c, s = np.cos(scan_poses[:, 2]), np.sin(scan_poses[:, 2])
    ox, oy = scan_poses[:, 0] + lidar_x * c, scan_poses[:, 1] + lidar_x * s
    dx = places[:, None, 0] - ox[None, :]
    dy = places[:, None, 1] - oy[None, :]
    bearing = np.arctan2(-s * dx + c * dy, c * dx + s * dy)
    visible = (np.hypot(dx, dy) <= SEEN_RANGE) & (np.abs(bearing) <= 0.5 * fov)
    return inside | visible.any(1)


def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(A, B) distances between points a (A, 2) and b (B, 2)."""
    return np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])


def motion_clear(
    behaviour: str,
    amount: float,
    direction: float,
    points: np.ndarray,
    scan_poses: np.ndarray,
    planner: PlannerParams,
    lidar_x: float,
    fov: float,
) -> bool:
    """True if the motion is admissible from the current pose: points (M, 2) and scan poses
    (P, 3) in base_link (everything seen now and remembered). Admissible like a planner
    sample (every circle centre farther than r + m from every point), or, for a robot that
    already stands closer than r + m (a stall often ends pinned at that boundary), never
    closer than it stands now; and every centre and r + m ring point along it seen
    (:func:`seen`)."""
    fp = planner.footprint
    limit = planner.admissible_clearance
    body = circle_centres(np.zeros((1, 3)), fp.centers_x)
    centres = circle_centres(motion_poses(behaviour, amount, direction), fp.centers_x)
    reach = float(np.abs(fp.centers_x).max()) + amount + limit + 0.05
    near = points[np.hypot(points[:, 0], points[:, 1]) <= reach] if len(points) else points
    if len(near):
        now = _distances(body, near).min()
        if _distances(centres, near).min() <= min(limit, now - CLEARANCE_TOLERANCE):
            return False
    angles = np.linspace(0.0, 2 * math.pi, RING, endpoint=False)
    ring = limit * np.column_stack((np.cos(angles), np.sin(angles)))
    places = np.concatenate((centres, (centres[:, None, :] + ring[None, :, :]).reshape(-1, 2)))
    return bool(seen(places, scan_poses, lidar_x, fov, body, fp.radius).all())


class _Running:
    """A behaviour under way: what it is, how much of it is done, since when."""

    def __init__(self, behaviour: str, amount: float, direction: float, pose: Pose, t: float):
        self.behaviour, self.amount, self.direction = behaviour, amount, direction
        self.last, self.t0, self.done = pose, t, 0.0
        self.braking_since: float | None = None
        """When the motion ended and the robot began to stop (None while it moves)."""

    def advance(self, pose: Pose) -> float:
        """Add the motion from the last pose to this one (turned angle or distance backed)
        along the behaviour; returns what remains of it."""
        if self.behaviour == "spin":
            self.done += self.direction * math.remainder(pose[2] - self.last[2], 2 * math.pi)
        else:
            self.done += math.hypot(pose[0] - self.last[0], pose[1] - self.last[1])
        self.last = pose
        return self.amount - self.done


class Recovery:
    """The recovery layer of one episode: call :meth:`command` once per control step.

    params: the recipe; planner: the footprint, margins and limits motions are checked with;
    control_period: s; lidar_x, fov: the lidar's offset along the body axis (m) and field of
    view (rad), for what a remembered scan can vouch for.
    """

    def __init__(
        self,
        params: RecoveryParams,
        planner: PlannerParams,
        control_period: float,
        lidar_x: float,
        fov: float,
    ) -> None:
        if params.window < control_period:
            raise ConfigError(
                f"progress window {params.window:g} s is shorter than one control step "
                f"({control_period:g} s)"
            )
        self.params, self.planner, self.dt = params, planner, control_period
        self.lidar_x, self.fov = lidar_x, fov
        self.checker = ProgressChecker(params.radius, params.window)
        self.memory = ScanMemory(int(round(params.memory / control_period)))
        self.started = 0
        """Recoveries started so far."""
        self.refused = 0
        """Failed progress checks after which no behaviour was admissible."""
        self._next = 0  # index in params.sequence of the behaviour to try next
        self._running: _Running | None = None
        self._world_points = np.zeros((0, 2))
        self._scan_poses = np.zeros((0, 3))

    @property
    def active(self) -> str | None:
        """The behaviour running now, or None."""
        return None if self._running is None else self._running.behaviour

    def command(
        self,
        t: float,
        pose: Pose,
        points: np.ndarray,
        goal_body: tuple[float, float],
        velocity: tuple[float, float] = (0.0, 0.0),
    ) -> RecoveryCommand | None:
        """The command of this control step, or None to let the controller and planner drive.

        t: s; pose: estimated (x, y, yaw); points: (M, 2) valid returns in base_link now;
        goal_body: the goal in base_link (a spin turns toward its side first); velocity: the
        estimated (v, w), m/s and rad/s: a behaviour whose motion is over commands a stop
        until the robot is at rest (REST, at most BRAKE_LIMIT), then hands back.
        """
        self.memory.add(pose, points)
        run = self._running
        if run is not None:
            if run.braking_since is None:
                cmd = self._continue(t, pose, points)
                if cmd is not None:
                    return cmd
                run.braking_since = t
            at_rest = abs(velocity[0]) <= REST[0] and abs(velocity[1]) <= REST[1]
            if not at_rest and t - run.braking_since < BRAKE_LIMIT - 1e-9:
                return RecoveryCommand(0.0, 0.0, run.behaviour)
            self._running = None
            self.checker.reset(t, pose)
            return None
        if not self.checker.stuck(t, pose) or self.started >= self.params.max_recoveries:
            return None
        self.checker.reset(t, pose)
        self._world_points, self._scan_poses = self.memory.merged(pose, self._reach())
        towards = 1.0 if goal_body[1] >= 0 else -1.0
        seq = self.params.sequence
        for k in range(len(seq)):
            behaviour = seq[(self._next + k) % len(seq)]
            amount = self.params.spin_angle if behaviour == "spin" else self.params.backup_distance
            for direction in (towards, -towards) if behaviour == "spin" else (1.0,):
                if self._clear(behaviour, self._ahead(behaviour, amount), direction, pose, points):
                    self._next = (self._next + k + 1) % len(seq)
                    self._running = _Running(behaviour, amount, direction, pose, t)
                    self.started += 1
                    return self._drive(self._running, amount)
        self.refused += 1
        return None

    def _clear(
        self, behaviour: str, amount: float, direction: float, pose: Pose, points: np.ndarray
    ) -> bool:
        """Is the motion admissible from pose, against the points seen now and, outside the
        lidar's present field of view (where the present scan is the truth), remembered?"""
        everything, poses = points, self._scan_poses.copy()
        if len(self._world_points):
            old = to_body(pose, self._world_points)
            bearing = np.arctan2(old[:, 1], old[:, 0] - self.lidar_x)
            everything = np.concatenate((points, old[np.abs(bearing) > 0.5 * self.fov]))
        if len(poses):
            poses[:, :2] = to_body(pose, poses[:, :2])
            poses[:, 2] -= pose[2]
        return motion_clear(
            behaviour, amount, direction, everything, poses, self.planner, self.lidar_x, self.fov
        )

    def _continue(self, t: float, pose: Pose, points: np.ndarray) -> RecoveryCommand | None:
        run = self._running
        assert run is not None
        remaining = run.advance(pose)
        if remaining <= 0.5 * MOTION_STEP or t - run.t0 > self.params.behaviour_timeout:
            return None
        ahead = self._ahead(run.behaviour, remaining)
        if not self._clear(run.behaviour, ahead, run.direction, pose, points):
            return None
        return self._drive(run, remaining)

    def _reach(self) -> float:
        """How far from base_link a remembered point can matter to a recovery motion, m."""
        p, fp = self.params, self.planner.footprint
        body = float(np.abs(fp.centers_x).max()) + self.planner.admissible_clearance
        return body + p.backup_distance + 2 * MOTION_STEP

    def _ahead(self, behaviour: str, remaining: float) -> float:
        """How much of the motion is checked now: ``lookahead`` seconds of it, at most what
        remains (rad for a spin, m for a back-up)."""
        p = self.params
        rate = p.spin_rate if behaviour == "spin" else p.backup_speed
        return min(remaining, rate * p.lookahead)

    def _drive(self, run: _Running, remaining: float) -> RecoveryCommand:
        """The command toward the rest of the motion, slowed so one period does not overshoot."""
        if run.behaviour == "spin":
            w = run.direction * min(self.params.spin_rate, remaining / self.dt)
            return RecoveryCommand(0.0, w, run.behaviour)
        v = min(self.params.backup_speed, remaining / self.dt)
        return RecoveryCommand(-v, 0.0, run.behaviour)
