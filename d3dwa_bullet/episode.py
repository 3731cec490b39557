"""Run one episode: sense -> estimate -> observe -> choose parameters -> plan -> drive.

The loop is the same for every method; only the controller differs. Termination is judged
on ground truth (a fact about the world, not the robot's belief): collision on a Bullet
contact or a true lidar range below the collision threshold (checked first), goal when
base_link is within the goal tolerance, timeout at the time limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from d3dwa_bullet.episode_config import EpisodeConfig  # re-exported: its old home
from d3dwa_bullet.episode_metrics import body_clearance, posture_displacement, trajectory_length
from d3dwa_bullet.episode_result import LOG_FIELDS, EpisodeResult  # re-exported: their old home
from d3dwa_bullet.params import PROGRESS_RADIUS, PlannerParams
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.planning.global_plan import make_global_planner, plan_log, steer
from d3dwa_bullet.planning.observation import build_observation, goal_in_body
from d3dwa_bullet.planning.observation_kinds import make_observer, observation_layout
from d3dwa_bullet.planning.planner import PlannerAction, PlanResult, plan
from d3dwa_bullet.planning.progress import NoProgressClock
from d3dwa_bullet.planning.recovery import Recovery, RecoveryCommand
from d3dwa_bullet.planning.scan_filter import ScanFilter, check_driven_filter
from d3dwa_bullet.planning.velocity_command import LocalPlanner, PlannerInputs
from d3dwa_bullet.sim.backend import make_simulator
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.scan import LaserScan, scan_points_body
from d3dwa_bullet.timing import perf
from d3dwa_bullet.world.cylinder_distance import world_distance
from d3dwa_bullet.world.model import World


def make_recovery(config: EpisodeConfig) -> Recovery | None:
    """The recovery layer of a config (None on the paper's stack): one per episode or replay."""
    if config.recovery is None:
        return None
    return Recovery(
        config.recovery, config.planner, config.sim.control_period,
        config.lidar.mount_x, config.lidar.fov,
    )  # fmt: skip


def observation_of(pose, velocity, goal, points: np.ndarray, config: EpisodeConfig) -> np.ndarray:
    """The observation from an estimate: the one function the simulator and bag replay share.

    pose (x, y, yaw) and velocity (v, w): the estimate; goal (x, y), same frame; points:
    (M, 2) valid returns in base_link. Returns (4 + K,) float64.
    """
    return build_observation(
        pose, velocity, goal, points, config.observation, config.planner.limits
    )


def plan_from(
    pose, velocity, goal, points: np.ndarray, action: PlannerAction, config: EpisodeConfig,
    local: LocalPlanner | None = None,
) -> PlanResult:  # fmt: skip
    """The DWA step from an estimate and the chosen parameters (shared with bag replay), or
    a velocity planner's command (``local``: ``Controller.velocity``)."""
    return step_plan(
        local, pose, velocity, points, goal_in_body(pose, goal), action, config.planner
    )


class Episode:
    """One episode as a stepping object: ``observe()`` then ``act(...)`` until ``outcome``.

    ``observe`` senses, judges termination on ground truth, and (if the episode goes on)
    builds the observation from the estimate; ``act`` plans with the given parameters and
    drives one control period. ``run_episode``, the Gymnasium env and the bag recorder all
    run this same loop. ``observation`` is the kind the controller reads (``paper``, or
    ``progress``: docs/design/observation.md#progress-observation).
    """

    def __init__(
        self,
        world: World,
        seed: int = 0,
        noise: NoiseModel | None = None,
        noise_name: str = "none",
        config: EpisodeConfig = EpisodeConfig(),
        gui: bool = False,
        observation: str = "paper",
        velocity_planner: LocalPlanner | None = None,
    ):
        self.world, self.seed, self.noise_name, self.config = world, seed, noise_name, config
        self.progress = make_observer(observation)
        """The progress entries' state (None for the paper's observation)."""
        self.obs_dim = len(observation_layout(observation))
        limit = world.time_limit if world.time_limit is not None else config.termination.time_limit
        self.max_steps = int(round(limit * config.sim.control_hz))
        self.sim = make_simulator(
            config.backend,
            world,
            sim=config.sim,
            limits=config.planner.limits,
            lidar=config.lidar,
            noise=noise,
            gui=gui,
        )
        self.outcome: str | None = None
        self.rows: list[tuple] = []
        self.observations: list[np.ndarray] = []
        self.truth: list[tuple[float, float, float]] = []
        self.scan: LaserScan | None = None
        self.points = np.zeros((0, 2))
        self.obs = np.zeros(self.obs_dim)
        self.estimate: tuple[tuple[float, float, float], tuple[float, float]] = (
            (0.0, 0.0, 0.0),
            (0.0, 0.0),
        )
        self.goal_distance = math.inf
        """Ground-truth distance from base_link to the goal at the last observe(), m."""
        self.obstacle_distance = math.inf
        """Smallest true valid lidar range at the last observe(), m (inf if none)."""
        self._truth_progress = NoProgressClock(PROGRESS_RADIUS)
        self.stalled_s = 0.0
        """Seconds since the true pose last made progress (left a PROGRESS_RADIUS circle), at
        the last observe(): what the stall penalty of the reward reads."""
        self.last_plan = None
        self.recovery = make_recovery(config)
        """The recovery layer around the controller (None on the paper's stack)."""
        self.scan_filter = ScanFilter(config.scan_filter)
        """The scan filter chain (per episode: its state starts empty)."""
        self.last_recovery: RecoveryCommand | None = None
        """What the recovery layer drove at the last act() (None: the planner drove)."""
        self.velocity_planner = velocity_planner
        """A velocity planner in place of the DWA (``Controller.velocity``; None: the DWA)."""
        self.plan = make_global_planner(config, world)
        """The global plan the controller follows (None on the paper's stack)."""
        self.goal = world.goal  # what the controller drives toward: the goal, or the carrot

    def observe(self) -> np.ndarray:
        """Sense and judge termination; returns the observation, (12,) or (17,) by the kind
        (the last one if over)."""
        sim, term, cfg = self.sim, self.config.termination, self.config
        t = perf()
        pose = sim.true_pose()
        self.truth.append(pose)
        t = sim.clock.charge("physics", t)
        scan, true_ranges = sim.sense()
        t = perf()
        valid = true_ranges[np.isfinite(true_ranges) & (true_ranges >= cfg.lidar.range_min)]
        self.goal_distance = math.hypot(self.world.goal[0] - pose[0], self.world.goal[1] - pose[1])
        self.obstacle_distance = float(valid.min()) if valid.size else math.inf
        self.stalled_s = self._truth_progress.update(int(round(sim.time * 1e9)), pose)
        # Collision first: touching an obstacle inside the goal tolerance is still a collision.
        contact = sim.in_contact()
        t = sim.clock.charge("physics", t)
        if contact or self.obstacle_distance < term.collision_distance:
            self.outcome = "collision"
        elif self.goal_distance <= term.goal_tolerance:
            self.outcome = "goal"
        elif sim.step_count >= self.max_steps:
            self.outcome = "timeout"
        self.scan = scan  # as the lidar gave it (what a recorded bag holds)
        self.points = scan_points_body(self.scan_filter(scan), cfg.lidar.mount)
        t = sim.clock.charge("observation", t)
        self.estimate = sim.estimate()
        est_pose, est_vel = self.estimate
        t = sim.clock.charge("estimator", t)
        self.goal, seen_goal = steer(self.plan, sim.time, est_pose, self.points, self.world.goal)
        self.obs = build_observation(
            est_pose, est_vel, seen_goal, self.points, cfg.observation, cfg.planner.limits
        )
        if self.progress is not None:
            self.obs = self.progress.extend(self.obs, scan.stamp_ns, est_pose)
        sim.clock.charge("observation", t)
        return self.obs

    def act(self, index: int, action: PlannerAction) -> PlanResult:
        """Plan with action's weights and horizon, and drive one control period; while the
        recovery layer (if any) recovers, it drives instead and the action is not used."""
        if self.outcome is not None:
            raise RuntimeError(
                f"episode is over ({self.outcome}); call observe() only before it ends"
            )
        est_pose, est_vel = self.estimate
        if self.progress is not None:  # what the controller chose, even if a recovery drives
            self.progress.chose(action)
        t0 = perf()
        t = self.sim.time
        goal = goal_in_body(est_pose, self.goal)
        rescue = None
        if self.recovery is not None:
            rescue = self.recovery.command(t, est_pose, self.points, (goal[0], goal[1]), est_vel)
        if rescue is None:
            result = step_plan(
                self.velocity_planner, est_pose, est_vel, self.points, goal, action,
                self.config.planner,
            )  # fmt: skip
        else:
            result = recovery_result(rescue)
        self.last_recovery = rescue
        self.sim.clock.charge("planner", t0)
        self.sim.step(result.v, result.w)
        self.observations.append(self.obs)
        self.rows.append(
            (
                t,
                *self.truth[-1],
                *est_pose,
                result.v,
                result.w,
                index,
                *action,
                float(result.fallback),
                0 if rescue is None else rescue.code,
            )
        )
        self.last_plan = result
        return result

    def result(self, method: str) -> EpisodeResult:
        """Metrics and log of the steps so far."""
        poses = np.asarray(self.truth)
        log = {name: np.asarray([r[i] for r in self.rows]) for i, name in enumerate(LOG_FIELDS)}
        clearance = (
            body_clearance(self.world, poses, distance=world_distance)
            if self.world.obstacles
            else np.array([np.inf])
        )
        steps = self.sim.step_count
        return EpisodeResult(
            world=self.world.name,
            method=method,
            seed=self.seed,
            outcome=self.outcome or "timeout",
            time_s=steps * self.config.sim.control_period,
            tl_m=trajectory_length(poses[:, :2]),
            pd_rad=posture_displacement(poses[:, 2]),
            min_clearance_m=float(clearance.min()),
            steps=steps,
            noise=self.noise_name,
            recovery=self.config.recovery_name,
            backend=self.config.backend,
            global_plan=self.config.global_plan_name,
            log=log
            | {"true_x": poses[:, 0], "true_y": poses[:, 1], "true_yaw": poses[:, 2]}
            | plan_log(self.plan),
            observations=np.asarray(self.observations).reshape(-1, self.obs_dim),
        )

    def close(self) -> None:
        self.sim.close()

    def __enter__(self) -> Episode:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_NO_SAMPLES = np.zeros((0, 2))
_NOTHING = np.zeros(0)


def command_result(v: float, w: float) -> PlanResult:
    """A command that no DWA sampled, as a PlanResult: no samples, index -1, no fallback."""
    return PlanResult(
        v=v, w=w, index=-1, fallback=False, samples=_NO_SAMPLES, progress=_NOTHING,
        clearance=_NOTHING, speed=_NOTHING, admissible=np.zeros(0, dtype=bool), scores=_NOTHING,
    )  # fmt: skip


def step_plan(
    local: LocalPlanner | None, pose, velocity, points: np.ndarray, goal: np.ndarray,
    action: PlannerAction, params: PlannerParams,
) -> PlanResult:  # fmt: skip
    """One planning step: the DWA with action's weights and horizon (local None), else a
    velocity planner's command (docs/design/external-methods.md#external-methods), given copies of the
    inputs. pose (x, y, yaw) and velocity (v, w): the estimate; points: (M, 2) m, base_link;
    goal: (2,) m, base_link."""
    if local is None:
        return plan(velocity, points, goal, action, params)
    copy = np.array  # a new float64 array each: nothing the planner writes reaches ours
    inputs = PlannerInputs(
        copy(points, dtype=np.float64).reshape(-1, 2), copy(pose, dtype=np.float64),
        copy(velocity, dtype=np.float64), copy(goal[:2], dtype=np.float64), params.limits,
        params.control_period,
    )  # fmt: skip
    v, w = local(inputs)
    return command_result(float(v), float(w))


def recovery_result(command: RecoveryCommand) -> PlanResult:
    """A recovery step as a PlanResult: its command, no samples (index -1, not a fallback)."""
    return command_result(command.v, command.w)


#: Called after each control step (the robot has moved): (episode, action index, action, plan).
StepHook = Callable[["Episode", int, PlannerAction, PlanResult], None]


def run_episode(
    world: World,
    controller: Controller,
    seed: int = 0,
    noise: NoiseModel | None = None,
    noise_name: str = "none",
    config: EpisodeConfig = EpisodeConfig(),
    gui: bool = False,
    on_step: StepHook | None = None,
) -> EpisodeResult:
    """Run one episode to goal, collision or timeout and return its metrics and log.

    The controller is reset with the episode seed first (:meth:`Controller.reset`), so a
    method that draws its actions (``random``) draws the same ones for the same seed."""
    check_driven_filter(controller.scan_filter, config.scan_filter, f"the {controller.name} policy")
    controller.reset(seed)
    with Episode(
        world, seed, noise, noise_name, config, gui, controller.observation, controller.velocity
    ) as ep:
        while True:
            obs = ep.observe()
            if ep.outcome is not None:
                break
            index, action = controller(obs)
            result = ep.act(index, action)
            if on_step is not None:
                on_step(ep, index, action, result)
        out = ep.result(controller.name)
    out.source = controller.origin
    # only an external method's controller counts its overruns (external.guard)
    out.overruns = getattr(controller, "overruns", 0)
    return out
