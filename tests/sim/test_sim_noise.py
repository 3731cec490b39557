"""Noise in the simulator: seeded reproducibility, the noise-free reference, observations from
the estimate, lidar dropout, odometry/EKF wiring, and no run through a contact under `harsh`."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, EpisodeResult, run_episode
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.geometry import wrap_angle
from d3dwa_bullet.method_specs import FIXED
from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.observation import build_observation, sector_ranges
from d3dwa_bullet.planning.planner import plan
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.noise_config import (
    ImuConfig,
    LidarNoiseConfig,
    NoiseConfig,
    OdometryConfig,
    PoseFixConfig,
)
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.registry import load_world, world_paths
from randomization import episode_noise, load_profile
from tools.bench import eval_estimator

#: "Noise on" with nothing corrupted in practice: the estimator path with exact sensors.
EXACT_SENSORS = NoiseConfig(lidar=LidarNoiseConfig(range_std=1e-12))
#: Every dropout kind a real driver emits: NaN, +inf and 0.0.
ALL_KINDS = (1 / 3, 1 / 3, 1 / 3)


def _run(world, method: str, profile: str, seed: int, hook=None) -> EpisodeResult:
    return run_episode(
        world, make_controller(method), seed=seed, noise=make_noise(profile, seed),
        noise_name=profile, on_step=hook,
    )  # fmt: skip


def _assert_same_episode(a: EpisodeResult, b: EpisodeResult) -> None:
    assert a.summary() == b.summary()
    assert a.log.keys() == b.log.keys()
    for key in a.log:
        assert np.array_equal(a.log[key], b.log[key], equal_nan=True), key
    assert np.array_equal(a.observations, b.observations)


def _robot_contacts(sim: Simulator) -> list[tuple]:
    """Bullet contacts between the robot and anything but the floor (i.e. the obstacles)."""
    return [
        c
        for c in p.getContactPoints(bodyA=sim.robot, physicsClientId=sim.client)
        if c[2] not in (sim.ground, sim.robot)
    ]


# -- reproducibility -------------------------------------------------------------------


@pytest.mark.parametrize("profile", ["real", "harsh"])
def test_same_seed_gives_the_same_noisy_episode_bit_for_bit(profile):
    world = load_world("TS3").with_task(time_limit=4.0)
    scans: dict[str, list[np.ndarray]] = {"a": [], "b": []}

    def keep(run):
        return lambda ep, *_: scans[run].append(ep.scan.ranges.copy())

    a = _run(world, "dwa2", profile, 7, keep("a"))
    b = _run(world, "dwa2", profile, 7, keep("b"))
    _assert_same_episode(a, b)
    assert len(scans["a"]) == len(scans["b"]) == a.steps > 0
    for ra, rb in zip(scans["a"], scans["b"], strict=True):
        assert np.array_equal(ra, rb, equal_nan=True)
    # The noise did something: the estimate is not ground truth.
    assert not np.array_equal(a.log["est_x"], a.log["x"])


@pytest.mark.parametrize("profile", ["real", "harsh"])
def test_different_seeds_give_different_episodes(profile):
    world = load_world("TS1").with_task(time_limit=3.0)
    a = _run(world, "dwa3", profile, 1)
    b = _run(world, "dwa3", profile, 2)
    assert not np.array_equal(a.log["est_x"], b.log["est_x"])
    assert not np.array_equal(a.observations, b.observations)


def test_noise_none_reproduces_the_noise_free_simulator_exactly():
    world = load_world("TS3").with_task(time_limit=5.0)
    controller = make_controller("dwa1")
    reference = run_episode(world, controller, seed=4, noise=None)
    for noise in (NoiseModel(), episode_noise(load_profile("none"), 4), make_noise("none", 4)):
        _assert_same_episode(reference, run_episode(world, controller, seed=4, noise=noise))
    # Noise-free, the robot's belief is ground truth.
    assert np.array_equal(reference.log["est_x"], reference.log["x"])
    assert np.array_equal(reference.log["est_yaw"], reference.log["yaw"])


# -- observation from the estimate -------------------------------------------------------


def _truth_observation(ep: Episode) -> np.ndarray:
    cfg = ep.config
    return build_observation(
        ep.sim.true_pose(), ep.sim.true_velocity(), ep.world.goal, ep.points, cfg.observation,
        cfg.planner.limits,
    )  # fmt: skip


def _drive(ep: Episode, steps: int, check) -> None:
    action = FIXED["dwa3"]
    for _ in range(steps):
        ep.observe()
        check(ep)
        if ep.outcome is not None:
            break
        ep.act(-1, action)


def test_observation_is_built_from_the_estimate_when_noise_is_on():
    # Odometry errors and no pose fix: the estimate drifts visibly from ground truth.
    cfg = NoiseConfig(odometry=OdometryConfig(radius_error_std=0.05, track_error_std=0.05))
    world = load_world("TS1").with_task(time_limit=5.0)
    differs = []

    def check(ep: Episode) -> None:
        pose, velocity = ep.sim.estimate()
        cfg_ = ep.config
        from_estimate = build_observation(
            pose, velocity, ep.world.goal, ep.points, cfg_.observation, cfg_.planner.limits
        )
        assert np.array_equal(ep.obs, from_estimate)
        differs.append(not np.allclose(ep.obs[:4], _truth_observation(ep)[:4], atol=1e-3))

    with Episode(world, seed=3, noise=NoiseModel(cfg, 3)) as ep:
        _drive(ep, 40, check)
    assert sum(differs) >= 20, "the observation should follow the drifting estimate"


def test_observation_is_built_from_ground_truth_when_noise_is_off():
    world = load_world("TS1").with_task(time_limit=3.0)

    def check(ep: Episode) -> None:
        assert np.array_equal(ep.obs, _truth_observation(ep))

    with Episode(world) as ep:
        _drive(ep, 15, check)


# -- lidar dropout ---------------------------------------------------------------------


def test_a_fully_dropped_scan_shows_no_obstacle(wall_world):
    with Episode(wall_world) as ep:  # the wall as the robot sees it without noise
        seen = ep.observe()[4:]
        clear = ep.act(-1, FIXED["dwa1"]).clearance
    assert seen.min() < 0.7 and clear.min() < PlannerParams().clearance_cap
    cfg = NoiseConfig(lidar=LidarNoiseConfig(dropout_prob=1.0, dropout_kinds=ALL_KINDS))
    with Episode(wall_world, noise=NoiseModel(cfg, 0)) as ep:
        obs = ep.observe()
        ranges = ep.scan.ranges
        assert np.isnan(ranges).any() and np.isinf(ranges).any() and (ranges == 0.0).any()
        assert ep.points.shape == (0, 2)
        assert np.array_equal(obs[4:], np.ones(8))  # no valid beam: every sector reads 1.0
        result = ep.act(-1, FIXED["dwa1"])
    # The planner saw an empty world: nothing within the clearance cap, nothing inadmissible.
    assert (result.clearance == PlannerParams().clearance_cap).all()
    assert not result.fallback and result.admissible.all()


def test_dropped_beams_are_skipped_not_turned_into_obstacles(post_world):
    cfg = NoiseConfig(lidar=LidarNoiseConfig(dropout_prob=0.5, dropout_kinds=ALL_KINDS))
    with Episode(post_world, seed=2, noise=NoiseModel(cfg, 2)) as ep:
        for _ in range(10):
            obs = ep.observe()
            scan, mount = ep.scan, ep.config.lidar.mount
            kept = scan.valid_mask()
            assert 0 < kept.sum() < kept.size
            # Every point the observation and planner get comes from a surviving beam ...
            assert ep.points.shape == (kept.sum(), 2) and np.isfinite(ep.points).all()
            assert np.hypot(ep.points[:, 0] - mount.x, ep.points[:, 1] - mount.y).min() >= (
                scan.range_min - 1e-6
            )
            # ... so dropping beams can only open sectors up, never close them in.
            lidar = ep.sim.lidar  # the same pose, uncorrupted (and no draw from the noise)
            full = lidar.scan(lidar.ranges(), scan.stamp_ns)
            truth_sectors = sector_ranges(scan_points_body(full, mount))
            assert (sector_ranges(ep.points) >= truth_sectors).all()
            assert np.all(obs[4:] >= np.clip(truth_sectors / 3.5, 0.0, 1.0))
            ep.act(-1, FIXED["dwa3"])


def test_invalid_ranges_from_a_real_driver_never_become_points():
    ranges = np.array([np.nan, np.inf, -np.inf, 0.0, 0.01, 20.0, 1.0, -1.0])
    scan = LaserScan(-0.35, 0.1, ranges, range_min=0.05, range_max=10.0)
    pts = scan_points_body(scan, Pose2D(0.156, 0.0, 0.0))
    assert pts.shape == (1, 2)  # only the 1.0 m beam
    assert math.hypot(pts[0, 0] - 0.156, pts[0, 1]) == pytest.approx(1.0)
    cleared = plan((0.0, 0.0), pts[:0], (2.0, 0.0), FIXED["dwa3"])
    assert cleared.admissible.all()


# -- odometry and estimator wiring -----------------------------------------------------


def _pose_error(a, b) -> tuple[float, float]:
    return math.hypot(a[0] - b[0], a[1] - b[1]), abs(wrap_angle(a[2] - b[2]))


def test_exact_sensors_keep_odometry_and_ekf_on_the_true_pose(open_world):
    # Exact encoders and gyro, no pose fix: what is left is dead reckoning. Accelerating and
    # turning must not bias it (rates are period means, fused before the prediction).
    with Simulator(open_world.with_task(goal=(5.0, 0.0)), noise=NoiseModel(EXACT_SENSORS)) as sim:
        for k in range(40):
            sim.step(0.3, 1.2 if k < 20 else -0.8)
            ekf_pos, ekf_yaw = _pose_error(sim.estimate()[0], sim.true_pose())
            odo_pos, odo_yaw = _pose_error(sim.odometry_pose(), sim.true_pose())
            assert ekf_yaw < 0.02 and odo_yaw < 0.03, k
            assert ekf_pos < 0.03 and odo_pos < 0.05, k


def test_ekf_beats_raw_odometry_under_odometry_errors(open_world):
    cfg = NoiseConfig(
        odometry=OdometryConfig(radius_error_std=0.02, track_error_std=0.02, walk_std=0.002),
        imu=ImuConfig(gyro_std=0.005, bias_std=0.005),
        pose_fix=PoseFixConfig(rate_hz=1.0, pos_std=0.03, yaw_std=0.02),
    )
    world = open_world.with_task(goal=(5.0, 0.0))
    odo, ekf = [], []
    for seed in range(3):
        with Simulator(world, noise=NoiseModel(cfg, seed)) as sim:
            for k in range(60):
                sim.step(0.3, 0.6 * math.sin(0.1 * k))
                odo.append(_pose_error(sim.odometry_pose(), sim.true_pose())[0])
                ekf.append(_pose_error(sim.estimate()[0], sim.true_pose())[0])
    assert np.sqrt(np.mean(np.square(ekf))) < 0.5 * np.sqrt(np.mean(np.square(odo)))


def test_eval_estimator_script_runs_on_a_tiny_budget():
    out = eval_estimator.run("TS1", "dwa3", "real", seeds=[0, 1], time_limit=2.0)
    assert out["seeds"] == [0, 1] and len(out["per_seed"]) == 2
    for key in ("odom_rmse_m", "ekf_rmse_m", "ekf_yaw_rmse_rad"):
        assert math.isfinite(out[key]) and out[key] >= 0.0
    assert out["samples"] == sum(r["steps"] for r in out["per_seed"]) == 40


# -- `harsh`: no crash, no run through a contact ----------------------------------------


def test_the_contact_probe_sees_a_drive_into_a_wall(wall_world):
    # The probe below must not be blind: drive straight at the wall under `harsh`.
    with Simulator(wall_world, noise=make_noise("harsh", 0)) as sim:
        touched = []
        for _ in range(100):
            sim.step(0.4, 0.0)
            touched.append(bool(_robot_contacts(sim)))
            assert touched[-1] == sim.in_contact()
    assert any(touched)


def _harsh_run_reports_every_contact(name: str, method: str, time_limit: float | None) -> str:
    world = load_world(name)
    if time_limit is not None:
        world = world.with_task(time_limit=time_limit)
    contact_steps: list[int] = []

    def check(ep: Episode, *_) -> None:
        if _robot_contacts(ep.sim):
            contact_steps.append(ep.sim.step_count)
        assert np.isfinite(ep.sim.estimator.state).all()

    res = _run(world, method, "harsh", 0, check)
    if contact_steps:
        # The first contact ends the episode as a collision, at that very step.
        assert res.outcome == "collision", f"{name} {method}: contact at {contact_steps}"
        assert contact_steps == [res.steps], f"{name} {method}: ran on through a contact"
    assert res.outcome in ("goal", "collision", "timeout")
    assert res.steps == len(res.log["t"]) and np.isfinite(res.observations).all()
    return res.outcome


@pytest.mark.parametrize("method", list(FIXED))
@pytest.mark.parametrize("name", ["TS3", "R2"])
def test_harsh_baselines_report_every_contact_short(name, method):
    _harsh_run_reports_every_contact(name, method, 10.0)


@pytest.mark.slow
@pytest.mark.parametrize("method", list(FIXED))
@pytest.mark.parametrize("name", list(world_paths()))
def test_harsh_baselines_report_every_contact_full(name, method):
    _harsh_run_reports_every_contact(name, method, None)
