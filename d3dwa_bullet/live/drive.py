"""The closed loop on a robot API (``d3dwa drive``, docs/design/live.md#live).

Every control period: read the scan and odometry (+ wheel odometry and IMU where served),
judge the episode, then the very decision of ``d3dwa replay`` and ``d3dwa run``
(:class:`transfer.sim_bridge.ReplayPipeline`: estimate -> observation -> controller ->
planner, and the recovery layer where asked), clamp the command to the robot's limits and
send it. The goal is in the odometry frame the robot reports, as ``replay`` takes it. Under
``--global-plan`` the pipeline's plan (the one an episode follows) turns the goal into a carrot
every step; each change of its status (no path, a goal inside an obstacle) is told, and the
carrot is then the goal itself (docs/design/global-plan.md#live-robot).

The episode is judged on what the robot reports, as a robot can only: collision when the
smallest valid scan range is below the collision distance, goal when the odometry pose is
within the goal tolerance, timeout after ``time_limit * control_hz`` commands. Every reading
is held to the contract the robot's sensors started with (``safety.ScanContract``,
``safety.OdometryCheck``): a blind scan is not decided on (a zero command holds the robot
still), a few in a row, a scan of another layout or odometry that makes no physical sense
end the run. A method from outside the package whose call took longer than its budget
(``external.guard``) is not obeyed: a zero command goes out in place of its late one, then the
run ends. Every way out (those, a stale, missing or broken reading, a gRPC error or deadline,
any exception, Ctrl-C, the watchdog) ends in ``set_robot_stop``.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from d3dwa_bullet.episode import EpisodeConfig, plan_from
from d3dwa_bullet.episode_metrics import posture_displacement, trajectory_length
from d3dwa_bullet.errors import ConfigError, ExternalMethodError, ScanError
from d3dwa_bullet.external.guard import ExternalController
from d3dwa_bullet.geometry import body_clearance_to_points, wrap_angle
from d3dwa_bullet.live.link import KachakaLink, Reading
from d3dwa_bullet.live.safety import (
    Freshness,
    OdometryCheck,
    ScanContract,
    SpeedLimits,
    Watchdog,
    deferred_interrupts,
    empty_sectors,
)
from d3dwa_bullet.planning.global_plan import GlobalPlanner, moved
from d3dwa_bullet.planning.planner import PlannerAction
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body
from transfer.replay_step import ScanStep, SkipScan, StepOutput
from transfer.sim_bridge import ReplayPipeline


@dataclass(frozen=True)
class DriveSettings:
    """One live run: goal (x, y) m in the odometry frame, and its limits."""

    goal: tuple[float, float]
    time_limit: float = 60.0
    """s; the run ends after time_limit * control_hz commands (as an episode's steps)."""
    limits: SpeedLimits = SpeedLimits()
    """Every command is clamped to these (default: the Kachaka API's)."""
    stale_s: float | None = None
    """A reading older than this is refused, s (None: two control periods). In lockstep a
    stamp unchanged over more than stale_s / control period commands is stale (the wall is
    not the robot's clock there); see ``safety.Freshness``."""
    watchdog_s: float = 0.5
    """The watchdog stops the robot when a loop iteration takes longer than this, s."""
    lockstep: bool = False
    """The robot advances one period per command (``d3dwa serve --lockstep``): no pacing."""


@dataclass
class DriveResult:
    """What a live run did, filled in as it goes (so a failed run still tells)."""

    outcome: str | None = None
    steps: int = 0
    poses: list[tuple[float, float, float]] = field(default_factory=list)
    """The odometry pose at every reading, the last one included."""
    commands: list[tuple[float, float]] = field(default_factory=list)
    """Every command sent (clamped), (v m/s, w rad/s)."""
    latencies: list[float] = field(default_factory=list)
    """Per step, s: from the read going out to the command acknowledged."""
    clearance: float = math.inf
    """Smallest distance from the body box to a valid scan point, m."""
    stopped: bool | None = None
    """Whether the final stop was acknowledged (False: the robot was unreachable)."""
    plan_events: list[tuple[int, str]] = field(default_factory=list)
    """(step, status) each time the global plan's status changed (none without a plan)."""

    def latency_ms(self, q: float) -> float | None:
        return float(np.percentile(self.latencies, q) * 1e3) if self.latencies else None

    def summary(
        self, method: str, robot: str, control_period: float, recovery: str = "none",
        global_plan: str = "none",
    ):  # fmt: skip
        """The row of ``d3dwa run``'s summary, judged on the robot's odometry and scan
        (world: the robot; seed and noise: none that drive knows), plus the robot's address,
        whether the stop was acknowledged, and loop latency p50 / p99 (ms); under a global plan
        its name and ``plan_events``, [step, status] at each change of its status."""
        poses = np.asarray(self.poses, dtype=np.float64).reshape(-1, 3)
        row: dict[str, Any] = {
            "world": "live",
            "method": method,
            "seed": None,
            "noise": "robot",
            "outcome": self.outcome or "stopped",
            "time_s": round(self.steps * control_period, 3),
            "tl_m": round(trajectory_length(poses[:, :2]), 4) if len(poses) else 0.0,
            "pd_rad": round(posture_displacement(poses[:, 2]), 4) if len(poses) else 0.0,
            "min_clearance_m": round(self.clearance, 4),
            "steps": self.steps,
        }
        if recovery != "none":
            row["recovery"] = recovery
        if global_plan != "none":
            row["global_plan"] = global_plan
            row["plan_events"] = [list(e) for e in self.plan_events]
        p50, p99 = self.latency_ms(50), self.latency_ms(99)
        return row | {
            "robot": robot,
            "stop_acknowledged": self.stopped,
            "latency_p50_ms": None if p50 is None else round(p50, 2),
            "latency_p99_ms": None if p99 is None else round(p99, 2),
        }


#: Called after each command: (reading, decision, command sent).
StepHook = Callable[[Reading, StepOutput, tuple[float, float]], None]
#: Called after each command: (step, distance to goal m, command, loop latency s).
ProgressHook = Callable[[int, float, tuple[float, float], float], None]
#: Called when the global plan's status changes: (step, status, one line saying what follows).
PlanHook = Callable[[int, str, str], None]

PLAN_NOTES = {
    "ok": "a path to the goal: following its carrot",
    "no_path": "no path on the costmap: driving toward the goal direction",
    "goal_blocked": "the goal lies inside an obstacle on the costmap: driving toward the goal direction",
    "outside": "the robot or the goal is outside the costmap: driving toward the goal direction",
}
"""What the live loop says of each global plan status (planning.global_plan.STATUSES)."""


def check_scan_layout(scan: LaserScan, mount: Pose2D, config: EpisodeConfig) -> None:
    """Refuse a scan whose beams leave a sector of the observation without a beam.

    The observation reads the smallest range per sector of base_link bearing, so any beam
    layout (count, spacing, field of view, a lidar turned on its mount) maps into the
    policy's K sectors; one that leaves a sector empty would make it read "free" forever.
    """
    obs = config.observation
    empty = empty_sectors(scan, np.ones(scan.ranges.size, dtype=bool), mount, obs)
    if empty.size:
        angles = np.degrees(scan.angles + mount.yaw)
        raise ScanError(
            f"the robot's scan ({scan.ranges.size} beams, {angles.min():.1f} to "
            f"{angles.max():.1f} deg) leaves observation sector(s) "
            f"{', '.join(map(str, empty))} of {obs.sectors} (over {np.degrees(obs.fov):.0f} deg) "
            "without a beam: they would read free space; refusing to drive"
        )


def check_goal_on_map(link: KachakaLink, goal: tuple[float, float], odom: Any) -> None:
    """Refuse a goal outside the robot's map (skipped where the robot serves no map).

    The goal is in the odometry frame; the map's pose of the robot and its odometry pose at
    the same moment give the odometry frame on the map.
    """
    grid = link.map()
    if grid is None or not grid.width or not grid.resolution:
        return
    gx, gy = moved(odometry_on_map(link, odom), goal)
    x0, y0 = grid.origin.x, grid.origin.y
    x1, y1 = x0 + grid.width * grid.resolution, y0 + grid.height * grid.resolution
    if not (x0 <= gx <= x1 and y0 <= gy <= y1):
        raise ConfigError(
            f"--goal {goal[0]:g},{goal[1]:g} lies outside the robot's map {grid.name!r} "
            f"(at ({gx:.2f}, {gy:.2f}) on it; the map spans x {x0:.2f}..{x1:.2f}, "
            f"y {y0:.2f}..{y1:.2f} m)"
        )


def odometry_on_map(link: KachakaLink, odom: Any) -> tuple[float, float, float]:
    """(x, y m, turn rad): where the odometry frame lies on the robot's map, from its pose on
    the map and its odometry pose at the same moment (a point p of the odometry frame is at
    (x, y) + R(turn) p on the map)."""
    mx, my, mt = link.robot_pose()
    ox, oy, ot = odom.pose
    turn = wrap_angle(mt - ot)
    c, s = math.cos(turn), math.sin(turn)
    return (mx - (c * ox - s * oy), my - (s * ox + c * oy), turn)


def warm_up(pipeline: ReplayPipeline) -> None:
    """Run the controller and the planner once on a dummy input, before the robot is
    involved: the planner's first call loads its compiled kernels, which the watchdog would
    take for a stall."""
    config = pipeline.config
    obs_dim = len(pipeline.observation_layout)
    pipeline.controller(np.zeros(obs_dim))
    pipeline.controller.reset(pipeline.seed)  # the random method's warm-up draw is not a step
    action = PlannerAction(1.0, 1.0, 1.0, 2.0)
    plan_from((0.0, 0.0, 0.0), (0.0, 0.0), (1.0, 0.0), np.zeros((0, 2)), action, config)
    first = pipeline.plan
    if first.params is not None:  # the path search's first call, on a throwaway plan
        period = config.sim.control_period
        plan = GlobalPlanner(
            first.params, config.planner, period, (0.0, 0.0, 0.0), (1.0, 0.0), first.known
        )
        plan.update(0.0, (0.0, 0.0, 0.0), np.zeros((0, 2)))


def drive(
    link: KachakaLink,
    pipeline: ReplayPipeline,
    settings: DriveSettings,
    *,
    result: DriveResult | None = None,
    on_step: StepHook | None = None,
    on_progress: ProgressHook | None = None,
    on_plan: PlanHook | None = None,
) -> DriveResult:
    """Drive until goal, collision or timeout; stop the robot on every way out.

    Checks before the first command: the robot's API version, that it serves a scan and
    odometry, the scan's beam layout (:func:`check_scan_layout`) and the goal against its
    map (:func:`check_goal_on_map`). Then every reading is checked against the first scan's
    contract (``safety.ScanContract``: ScanError) and for sane odometry
    (``safety.OdometryCheck``: RobotLinkError). result: filled in place (pass one to keep
    what a run that raises did). RobotLinkError on a lost, late or stale robot;
    ExternalMethodError on an external method's call over its budget, after the zero command
    sent in its place; the exception of any other failure, after the stop. Under a global plan
    (the pipeline's, as an episode follows it) every change of its status is kept in
    ``plan_events`` and told to on_plan; no path is never an error: the carrot is the goal.
    """
    out = result if result is not None else DriveResult()
    watchdog = Watchdog(settings.watchdog_s, link.stop)
    with deferred_interrupts() as interrupted:
        try:
            hooks = (on_step, on_progress, on_plan)
            _loop(link, pipeline, settings, out, watchdog, interrupted, *hooks)
        finally:
            watchdog.close()
            out.stopped = link.stop()
    return out


def _loop(
    link: KachakaLink,
    pipeline: ReplayPipeline,
    settings: DriveSettings,
    out: DriveResult,
    watchdog: Watchdog,
    interrupted: threading.Event,
    on_step: StepHook | None,
    on_progress: ProgressHook | None,
    on_plan: PlanHook | None,
) -> None:
    """The checks, then steps until the episode ends (``out.outcome``) or an error raises."""
    config = pipeline.config
    period = config.sim.control_period
    term = config.termination
    mount = config.lidar.mount
    goal = np.asarray(settings.goal, dtype=np.float64)
    max_steps = int(round(settings.time_limit * config.sim.control_hz))
    stale_s = settings.stale_s if settings.stale_s is not None else 2 * period
    fresh = Freshness(stale_s, period if settings.lockstep else None)
    link.check_version()
    first = link.read()
    check_scan_layout(first.scan, mount, config)
    contract = ScanContract(first.scan, mount, config.observation)
    limits = config.planner.limits
    odometry = OdometryCheck(
        max(limits.v_max, settings.limits.v_max), max(limits.w_max, settings.limits.w_max)
    )
    odometry.check(first, link.address)  # before the goal is placed by it
    check_goal_on_map(link, settings.goal, first.odometry)
    if pipeline.plan.known is not None:  # map: the map file is in the robot's map frame
        frame = odometry_on_map(link, first.odometry)
        pipeline.plan.frame = None if frame == (0.0, 0.0, 0.0) else frame
    watchdog.start()
    deadline = time.monotonic()
    reading: Reading | None = first
    while not interrupted.is_set():
        started = time.perf_counter()
        if reading is None:
            reading = link.read()
        stamps = {"scan": reading.scan.stamp_ns, "odometry": reading.odometry.stamp_ns}
        # lockstep: the robot's time is the commands sent, whatever the wall says
        now = out.steps if settings.lockstep else time.monotonic()
        fresh.check(stamps, now, link.address)
        odometry.check(reading, link.address)
        blind = contract.check(reading.scan)
        pose = reading.odometry.pose
        out.poses.append(pose)
        points = scan_points_body(reading.scan, mount)
        valid = reading.scan.ranges[reading.scan.valid_mask()]
        out.clearance = min(out.clearance, body_clearance_to_points(points))
        distance = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
        if valid.size and valid.min() < term.collision_distance:
            out.outcome = "collision"
        elif distance <= term.goal_tolerance:
            out.outcome = "goal"
        elif out.steps >= max_steps:
            out.outcome = "timeout"
        if out.outcome is not None:
            return
        late = None
        if blind is None:
            decided = _decide(pipeline, reading, mount, goal)
            _plan_event(pipeline, out, on_plan)
            assert decided.cmd is not None
            command = settings.limits.clamp(*decided.cmd)
            late = _late_call(pipeline)
            if late is not None:  # a late command acts on an old scan: stop in its place
                command = (0.0, 0.0)
        else:  # never decide on what the robot cannot see: hold still
            decided, command = _hold(reading), (0.0, 0.0)
        watchdog.send(link.command, *command)
        out.steps += 1
        out.commands.append(command)
        latency = time.perf_counter() - started
        out.latencies.append(latency)
        watchdog.beat()
        if on_step is not None:
            on_step(reading, decided, command)
        if on_progress is not None:
            on_progress(out.steps, distance, command, latency)
        if late is not None:
            raise late
        reading = None
        if not settings.lockstep:
            deadline = _pace(deadline, period, interrupted)
    raise KeyboardInterrupt


def _decide(pipeline: ReplayPipeline, reading: Reading, mount: Pose2D, goal: np.ndarray):
    """The decision of one reading: ``ReplayPipeline`` on the step a bag replay would see."""
    wheel = reading.wheel
    step = ScanStep(
        t_ns=reading.scan.stamp_ns,
        scan=reading.scan,
        mount=mount,
        odom_pose=np.asarray(reading.odometry.pose, dtype=np.float64),
        odom_twist=np.asarray(reading.odometry.twist, dtype=np.float64),
        goal=goal,
        wheel_twist=None if wheel is None else np.asarray(wheel.twist, dtype=np.float64),
        imu_w=reading.imu_w,
    )
    try:
        return pipeline(step)
    except SkipScan as err:
        raise ScanError(f"cannot decide at stamp {step.t_ns} ns: {err.reason}") from err


def _plan_event(pipeline: ReplayPipeline, out: DriveResult, on_plan: PlanHook | None) -> None:
    """Keep (and tell) the global plan's status when the step just decided changed it."""
    plan = pipeline.plan.plan
    if plan is None or len(plan.events) <= len(out.plan_events):
        return
    status = plan.events[-1][1]
    out.plan_events.append((out.steps, status))
    if on_plan is not None:
        on_plan(out.steps, status, PLAN_NOTES[status])


def _late_call(pipeline: ReplayPipeline) -> ExternalMethodError | None:
    """The refusal of an external method's call over its budget this step (None: in time,
    or a built-in method, which has no budget)."""
    controller = pipeline.controller
    return controller.late_call() if isinstance(controller, ExternalController) else None


def _hold(reading: Reading) -> StepOutput:
    """The step of a blind scan: no observation, no decision, a zero command."""
    odom = reading.odometry
    return StepOutput(np.zeros(0), odom.pose, odom.twist, cmd=(0.0, 0.0))


def _pace(deadline: float, period: float, interrupted: threading.Event) -> float:
    """Sleep until the next control tick (or an interrupt); a late loop restarts its ticks
    from now."""
    deadline += period
    delay = deadline - time.monotonic()
    if delay > 0:
        interrupted.wait(delay)
        return deadline
    return time.monotonic()
