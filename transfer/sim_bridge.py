"""The simulator's decision pipeline as a bag replay step, and simulated episodes as bags.

``transfer`` knows bags; this module knows the simulator. It plugs the two together so a
recorded scan goes through the very code an episode runs at every control step:

    estimate -> build_observation -> controller (policy) -> plan(goal_in_body(...))

with the same parameter objects (``EpisodeConfig``) as ``Episode.observe`` / ``Episode.act``.

Recording (``record_episode``): one message per control step k, stamped with the bag time
of sim time t_k (bag time = sim time + ``start_ns``, 1 s by default: a zero header stamp
means "unset" in ROS and would make the reader fall back to receive times):

* ``/kachaka/lidar/scan``: the scan the observation was built from (float32 already in the
  simulator, so it replays bit for bit);
* ``/kachaka/odometry/odometry`` and ``/tf`` odom -> base_link: the robot's *estimate*, the
  pose and velocity the observation was built from (EKF with noise on, ground truth
  without); on a real Kachaka this topic is the robot's own fused odometry;
* ``/kachaka/manual_control/cmd_vel``: the planner's command;
* ``/d3dwa/planner_params``: [wp, wc, ws, tau, action_index] (index -1: a fixed method);
* ``/kachaka/wheel_odometry/wheel_odometry`` and ``/kachaka/imu/imu``: raw wheel odometry
  and gyro, one sample per control period from t = 0, stamped when the simulator produced
  them (mean rates over the period just ended: the readings its EKF fused);
* once: ``/goal_pose`` (in ``odom``) and ``/tf_static`` (lidar and IMU mounts).

Replay (``make_step_fn``): with ``estimator="odometry"`` (the default) the bag's odometry
*is* the estimate, exactly as on the robot, and a replay of a recorded episode reproduces
the simulator's observations and chosen actions bit for bit. ``estimator="ekf"`` re-fuses
wheel odometry and gyro with the simulator's ``PoseEstimator`` (no absolute pose fixes), for
bags from robots that publish no fused odometry; that mode is *not* bit-exact against the
simulator, whose EKF also fuses its localisation fixes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import (
    Episode,
    EpisodeConfig,
    make_recovery,
    observation_of,
    plan_from,
    recovery_result,
    run_episode,
)
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.geometry import wrap_angle_modular
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.planning.global_plan import FirstStepPlan
from d3dwa_bullet.planning.observation import goal_in_body
from d3dwa_bullet.planning.observation_kinds import Observer, make_observer, observation_layout
from d3dwa_bullet.planning.planner import PlannerAction, PlanResult
from d3dwa_bullet.planning.recovery import RecoveryCommand
from d3dwa_bullet.planning.scan_filter import ScanFilter, check_driven_filter
from d3dwa_bullet.sim.estimator import EstimatorConfig, PoseEstimator
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.scan import scan_points_body
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import load_world
from transfer.replay_step import ESTIMATORS, Estimator, ScanStep, SkipScan, StepOutput

#: Bag time of sim time 0, ns.
DEFAULT_START_NS = 1_000_000_000
#: Skip reason of a scan whose estimate (bag odometry, or the EKF fed from it) is NaN/inf.
SKIP_NON_FINITE_ESTIMATE = "non-finite pose or velocity estimate"

Pose = tuple[float, float, float]
Twist = tuple[float, float]


# -- replay ----------------------------------------------------------------------------


def decide(
    pose: Any,
    velocity: Any,
    goal: Any,
    points: np.ndarray,
    controller: Controller,
    config: EpisodeConfig = EpisodeConfig(),
    progress: Observer | None = None,
    t_ns: int = 0,
    seen: Any = None,
) -> tuple[np.ndarray, int, PlannerAction, PlanResult]:
    """One control decision from an estimate: what ``Episode.observe`` + ``act`` compute.

    pose: (x, y, yaw) m/rad and velocity: (v, w) m/s, rad/s, the estimate, odometry frame;
    goal: (x, y) m, same frame, what the planner drives toward (the carrot under a global plan);
    seen: the goal the observation reads (None: goal); points: (M, 2) float64 valid returns, m,
    base_link.
    progress: a progress-aware controller's observer (one per bag), fed the estimated pose
    at t_ns (int ns) as ``Episode.observe`` feeds it the simulated one.
    Returns (observation (12,) or (17,), action index, action, plan result).
    """
    obs = observation_of(pose, velocity, goal if seen is None else seen, points, config)
    if progress is not None:
        obs = progress.extend(obs, t_ns, pose)
    index, action = controller(obs)
    if progress is not None:
        progress.chose(action)
    result = plan_from(pose, velocity, goal, points, action, config, controller.velocity)
    return obs, index, action, result


class _EkfEstimate:
    """Wheel odometry + gyro fused by the simulator's EKF, started at the first odometry pose.

    Same order as ``Simulator._fuse``: the readings at t are means over the period ending at
    t, so they are fused first, then the filter predicts to t. Without wheel odometry in the
    bag the pose source's twist stands in for it; no absolute pose fixes are fused.
    """

    def __init__(self, config: EstimatorConfig) -> None:
        self.config = config
        self.ekf: PoseEstimator | None = None

    def __call__(self, step: ScanStep) -> tuple[np.ndarray, np.ndarray]:
        t = step.t_ns / 1e9
        if self.ekf is None:
            self.ekf = PoseEstimator(self.config, pose=tuple(step.odom_pose), t=t)
        twist = step.wheel_twist if step.wheel_twist is not None else step.odom_twist
        if np.isfinite(twist).all():
            self.ekf.update_odometry(float(twist[0]), float(twist[1]))
        if step.imu_w is not None and math.isfinite(step.imu_w):
            self.ekf.update_gyro(step.imu_w)
        self.ekf.predict(t)
        return self.ekf.pose, self.ekf.velocity


class ReplayPipeline:
    """A ``transfer.replay`` step function: one recorded scan -> estimate, observation,
    action, planner command. Stateful in EKF mode, for a progress-aware controller (time
    since progress on the estimate, the previous action) and for the ``random`` method (its
    draws): one instance per replay. ``seed`` is the episode seed the controller is reset
    with (:meth:`Controller.reset`): a recorded episode's seed replays its random actions."""

    def __init__(
        self,
        controller: Controller,
        *,
        estimator: Estimator = "odometry",
        config: EpisodeConfig = EpisodeConfig(),
        estimator_config: EstimatorConfig = EstimatorConfig(),
        seed: int = 0,
        known_map: World | None = None,
    ) -> None:
        if estimator not in ESTIMATORS:
            raise ConfigError(
                f"unknown estimator {estimator!r}: choose one of {', '.join(ESTIMATORS)}"
            )
        check_driven_filter(
            controller.scan_filter, config.scan_filter, f"the {controller.name} policy"
        )
        self.seed = seed
        controller.reset(seed)
        self.controller = controller
        self.config = config
        self.estimator = estimator
        self._ekf = _EkfEstimate(estimator_config) if estimator == "ekf" else None
        self.progress = make_observer(controller.observation)
        self.observation_layout = observation_layout(controller.observation)
        self.recovery = make_recovery(config)
        """The recovery layer around the controller, as ``Episode`` runs it (None: the paper's
        stack), on :meth:`recovery_clock`."""
        self.last_recovery: RecoveryCommand | None = None
        """What the recovery layer drove at the last step (None: the planner drove)."""
        self.scan_filter = ScanFilter(config.scan_filter)
        """The scan filter chain, as ``Episode`` runs it (its state lives for one replay)."""
        self._t0_ns: int | None = None
        self.plan = FirstStepPlan(config, known_map)
        """The global plan the planner follows, as ``Episode`` runs it (``map``: on known_map)."""

    def recovery_clock(self, t_ns: int) -> float:
        """Seconds since the first step's stamp. On the control grid (stamps k periods apart to
        the ns, as a simulated robot's are) it is k x period, the very float ``Episode`` gives
        the recovery layer (its step count x period), where the ns difference / 1e9 differs in
        the last bit for about a third of all k and can move a progress window's end by a
        step; off the grid (a real robot's stamps), the difference itself."""
        if self._t0_ns is None:
            self._t0_ns = t_ns
        elapsed_ns = t_ns - self._t0_ns
        period = self.config.sim.control_period
        k = round(elapsed_ns / (period * 1e9))
        if elapsed_ns == round(k * period * 1e9):
            return k * period
        return elapsed_ns / 1e9

    def __call__(self, step: ScanStep) -> StepOutput:
        if self._ekf is not None:
            pose, velocity = self._ekf(step)
        else:
            pose, velocity = step.odom_pose, step.odom_twist
        if not (np.isfinite(pose).all() and np.isfinite(velocity).all()):
            raise SkipScan(SKIP_NON_FINITE_ESTIMATE)
        points = scan_points_body(self.scan_filter(step.scan), step.mount)
        carrot, seen = self.plan.steer(self.recovery_clock(step.t_ns), pose, points, step.goal)
        obs, index, action, result = decide(
            pose, velocity, carrot, points, self.controller, self.config,
            self.progress, step.t_ns, seen,
        )  # fmt: skip
        if self.recovery is not None:  # as Episode.act: the controller chose, a recovery drives
            goal = goal_in_body(pose, carrot)
            self.last_recovery = self.recovery.command(
                self.recovery_clock(step.t_ns), tuple(pose), points, (goal[0], goal[1]),
                tuple(velocity),
            )  # fmt: skip
            if self.last_recovery is not None:
                result = recovery_result(self.last_recovery)
        return StepOutput(
            observation=obs,
            pose=pose,
            velocity=velocity,
            action=index,
            weights=(action.wp, action.wc, action.ws),
            tau=action.tau,
            cmd=(result.v, result.w),
        )


def make_step_fn(
    method: str,
    policy: str | Path | None = None,
    *,
    estimator: Estimator = "odometry",
    config: EpisodeConfig = EpisodeConfig(),
    seed: int = 0,
) -> ReplayPipeline:
    """The replay step of a method (``d3dwa replay --method``); loads its policy now, so a
    missing checkpoint fails before the bag is read. seed: the episode seed (``--seed``),
    which only the ``random`` method draws from."""
    return ReplayPipeline(
        make_controller(method, policy), estimator=estimator, config=config, seed=seed
    )


# -- recording ---------------------------------------------------------------------------


class GyroTap:
    """Keeps every gyro reading a NoiseModel hands to the simulator's EKF, in call order.

    The Simulator fuses its gyro reading without storing it; wrapping this episode's own
    NoiseModel.gyro observes it with the same calls and the same random draws, so the
    episode is unchanged (tests check that a recorded episode equals an unrecorded one).
    """

    def __init__(self, noise: NoiseModel) -> None:
        self.readings: list[float] = []
        self._gyro = noise.gyro
        noise.gyro = self  # type: ignore[method-assign]

    def __call__(self, w_true: float, dt: float) -> float:
        reading = self._gyro(w_true, dt)
        self.readings.append(reading)
        return reading


def mean_body_rates(start: Pose, end: Pose, dt: float) -> Twist:
    """(v, w), m/s and rad/s: the constant-rate arc that takes pose start to pose end in dt.

    The inverse of ``odometry.arc_step`` (sideways motion is dropped): what perfect wheel
    encoders and a perfect gyro, averaged over the period, report.
    """
    w = wrap_angle_modular(end[2] - start[2]) / dt
    half = 0.5 * w * dt
    mid = start[2] + half
    along = (end[0] - start[0]) * math.cos(mid) + (end[1] - start[1]) * math.sin(mid)
    sinc = math.sin(half) / half if abs(half) > 1e-9 else 1.0 - half * half / 6.0
    return along / (dt * sinc), w


class EpisodeRecorder:
    """``on_step`` hook of ``run_episode`` that writes each control step into a BagRecorder.

    Decision-time messages (scan, estimate, tf, command, planner parameters) are stamped with
    the scan's own time, so the hook does not depend on whether it runs before or after the
    robot moves. Wheel odometry and gyro are stamped with the simulator time they were
    produced at, one sample per control period from t = 0, and hold, like the simulator's
    sensors, the mean rates over the period just ended: with noise on the encoder odometry
    and the gyro reading the EKF fused, with noise off the exact rates from ground truth.
    """

    def __init__(
        self,
        recorder: Any,
        world: World,
        config: EpisodeConfig,
        tap: GyroTap | None,
        start_ns: int = DEFAULT_START_NS,
    ) -> None:
        self.recorder, self.world, self.config, self.tap = recorder, world, config, tap
        self.start_ns = int(start_ns)
        self.steps = 0
        self._sensor_steps = 0  # wheel/IMU samples written: control periods 0 .. n-1

    def _bag_ns(self, sim_ns: int) -> int:
        return self.start_ns + int(sim_ns)

    def _period_ns(self, k: int) -> int:
        return int(round(k * self.config.sim.control_period * 1e9))

    def __call__(self, ep: Episode, index: int, action: PlannerAction, result: PlanResult) -> None:
        rec = self.recorder
        assert ep.scan is not None
        t = self._bag_ns(ep.scan.stamp_ns)
        pose, velocity = ep.estimate
        rec.write_step(
            t,
            replace(ep.scan, stamp_ns=t),
            pose,
            velocity,
            cmd=(result.v, result.w),
            params=(*action, float(index)),
        )
        if self.steps == 0 and getattr(rec, "goal", None) is None:
            rec.write_goal(t, self.world.goal)
        self.steps += 1
        self._write_sensors(ep)

    def _write_sensors(self, ep: Episode) -> None:
        sim = ep.sim
        while self._sensor_steps <= sim.step_count:
            k = self._sensor_steps
            wheel_pose, wheel_twist = self._wheel(ep, k)
            gyro = self.tap.readings[k] if self.tap is not None and sim.noisy else wheel_twist[1]
            t = self._bag_ns(self._period_ns(k))
            self.recorder.write_odometry(t, wheel_pose, wheel_twist, wheel=True)
            self.recorder.write_imu(t, gyro)
            self._sensor_steps += 1

    def _wheel(self, ep: Episode, k: int) -> tuple[Pose, Twist]:
        """Wheel-odometry pose and mean twist at the end of control period k."""
        sim = ep.sim
        if k == 0:  # the reset: at rest, wheel odometry started at the world's start pose
            return (self.world.start if sim.noisy else self._true_pose(ep, 0)), (0.0, 0.0)
        if sim.noisy:  # k == sim.step_count: the reading of the period that just ended
            return sim.odometry_pose(), (sim.odometry.v, sim.odometry.w)
        pose = self._true_pose(ep, k)
        return pose, mean_body_rates(
            self._true_pose(ep, k - 1), pose, self.config.sim.control_period
        )

    @staticmethod
    def _true_pose(ep: Episode, k: int) -> Pose:
        return ep.truth[k] if k < len(ep.truth) else ep.sim.true_pose()


def record_episode(
    world: str | Path | World,
    method: str,
    policy: str | Path | None,
    noise: str,
    seed: int,
    recorder: Any,
    *,
    config: EpisodeConfig = EpisodeConfig(),
    time_limit: float | None = None,
    start_ns: int = DEFAULT_START_NS,
    on_result: Callable[[Any], None] | None = None,
) -> dict[str, Any]:
    """Run one episode and write every control step into ``recorder`` (a BagRecorder).

    world: a World or a name/path for ``load_world``; noise: randomisation profile name or
    YAML path ("none" for none); time_limit: s, overrides the world's. Returns the episode
    summary (``EpisodeResult.summary()``); ``on_result`` receives the full EpisodeResult.
    """
    w = world if isinstance(world, World) else load_world(world)
    if time_limit is not None:
        w = w.with_task(time_limit=time_limit)
    lidar = config.lidar
    mount = (lidar.mount_x, lidar.mount_y, lidar.mount_z)
    rec_mount = tuple(getattr(recorder, "lidar_mount", mount))
    if rec_mount != mount:
        raise ConfigError(
            f"recorder lidar mount {rec_mount} differs from the simulated lidar's {mount}: "
            "a replay would build different observations"
        )
    controller = make_controller(method, policy)
    noise_model = make_noise(noise, seed)
    tap = GyroTap(noise_model) if noise_model is not None else None
    hook = EpisodeRecorder(recorder, w, config, tap, start_ns)
    result = run_episode(
        w, controller, seed=seed, noise=noise_model, noise_name=str(noise), config=config,
        on_step=hook,
    )  # fmt: skip
    if on_result is not None:
        on_result(result)
    return result.summary()
