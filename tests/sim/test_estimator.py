"""Wheel odometry and the EKF pose estimator, on synthetic data (no simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError, EstimatorError
from d3dwa_bullet.geometry import arc_step, wrap_angle
from d3dwa_bullet.robot import TRACK, WHEEL_RADIUS
from d3dwa_bullet.sim.estimator import EstimatorConfig, PoseEstimator, unicycle_jacobian
from d3dwa_bullet.sim.noise import NoiseModel, encoder_wheel_speed, ground_wheel_speed
from d3dwa_bullet.sim.noise_config import ImuConfig, NoiseConfig, OdometryConfig, PoseFixConfig
from d3dwa_bullet.sim.odometry import WheelOdometry

R, DT = WHEEL_RADIUS, 0.1


def wheel_speeds(v: float, w: float) -> tuple[float, float]:
    """True encoder speeds (rad/s) for body twist (v, w)."""
    return (v - 0.5 * TRACK * w) / R, (v + 0.5 * TRACK * w) / R


def angle_diff(a: float, b: float) -> float:
    return abs(wrap_angle(a - b))


# ---- odometry -------------------------------------------------------------------------


def test_odometry_exact_on_straight_line() -> None:
    odo = WheelOdometry(R, TRACK)
    for _ in range(50):
        x, y, yaw, v, w = odo.update(*wheel_speeds(0.3, 0.0), DT)
    assert x == pytest.approx(0.3 * 5.0, abs=1e-12) and y == 0.0 and yaw == 0.0
    assert (v, w) == pytest.approx((0.3, 0.0), abs=1e-12)


@pytest.mark.parametrize(("v", "w"), [(0.3, 0.5), (0.2, -1.0), (0.0, 2.0), (0.4, 0.01)])
def test_odometry_exact_on_circle(v: float, w: float) -> None:
    odo = WheelOdometry(R, TRACK)
    odo.reset((1.0, -2.0, 0.3))
    for k in range(1, 101):
        x, y, yaw, _, _ = odo.update(*wheel_speeds(v, w), DT)
        t = k * DT
        # Closed form for a circle of radius v/w from (1, -2) heading 0.3.
        if abs(w) > 0:
            ex = 1.0 + v / w * (math.sin(0.3 + w * t) - math.sin(0.3))
            ey = -2.0 - v / w * (math.cos(0.3 + w * t) - math.cos(0.3))
        assert (x, y) == pytest.approx((ex, ey), abs=1e-9)
        assert angle_diff(yaw, 0.3 + w * t) < 1e-9


def test_odometry_full_circle_returns_home() -> None:
    odo = WheelOdometry(R, TRACK)
    w = 2 * math.pi / 10.0  # one turn in 10 s
    for _ in range(100):
        x, y, yaw, _, _ = odo.update(*wheel_speeds(0.3, w), DT)
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-9) and angle_diff(yaw, 0.0) < 1e-9


@pytest.mark.parametrize(
    "config",
    [
        OdometryConfig(radius_error_std=0.02),
        OdometryConfig(track_error_std=0.05),
        OdometryConfig(walk_std=0.01, yaw_walk_std=0.01),
    ],
)
def test_odometry_drifts_with_errors(config: OdometryConfig) -> None:
    truth, odo = WheelOdometry(R, TRACK), WheelOdometry(R, TRACK, config, np.random.default_rng(1))
    again = WheelOdometry(R, TRACK, config, np.random.default_rng(1))
    for _ in range(200):
        speeds = wheel_speeds(0.3, 0.4)
        t, o, a = truth.update(*speeds, DT), odo.update(*speeds, DT), again.update(*speeds, DT)
        assert o == a  # deterministic for the same rng
    assert math.hypot(o[0] - t[0], o[1] - t[1]) > 1e-3


def test_odometry_needs_rng_when_on_and_finite_inputs() -> None:
    with pytest.raises(ConfigError, match="rng"):
        WheelOdometry(config=OdometryConfig(walk_std=0.1))
    with pytest.raises(ConfigError, match="track"):
        WheelOdometry(track=0.0)
    odo = WheelOdometry()
    with pytest.raises(EstimatorError, match="omega_left"):
        odo.update(math.nan, 1.0, DT)
    with pytest.raises(EstimatorError, match="dt"):
        odo.update(1.0, 1.0, -0.1)


def test_odometry_overestimates_under_slip() -> None:
    """Encoder sees the un-slipped wheel speed, so odometry runs ahead of the truth."""
    truth, odo = WheelOdometry(R, TRACK), WheelOdometry(R, TRACK)
    slip = np.array([0.05, 0.05])
    cmd = np.array(wheel_speeds(0.3, 0.0))
    for _ in range(30):
        joint = ground_wheel_speed(cmd, slip)
        truth.update(*joint, DT)
        odo.update(*encoder_wheel_speed(joint, slip), DT)
    assert odo.x > truth.x


# ---- EKF ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "state", [[1.0, 2.0, 0.3, 0.4, 1.3], [0.0, 0.0, -2.0, 0.3, 1e-6], [0.0, 0.0, 3.0, -0.2, -2.0]]
)
def test_jacobian_matches_finite_differences(state: list[float]) -> None:
    s, dt = np.array(state), 0.7

    def f(u: np.ndarray) -> np.ndarray:
        return np.array([*arc_step(*u, dt), u[3], u[4]])

    num = np.column_stack([(f(s + e) - f(s - e)) / 2e-6 for e in np.eye(5) * 1e-6])
    assert np.allclose(unicycle_jacobian(s, dt), num, atol=1e-7)


def simulate(seed: int, with_fix: bool = True, duration: float = 60.0) -> dict[str, float]:
    """A wiggly unicycle run; returns position RMSE of dead reckoning and of the EKF."""
    fix_config = (
        PoseFixConfig(rate_hz=1.0, pos_std=0.05, yaw_std=0.03, dropout_prob=0.1)
        if with_fix
        else PoseFixConfig()
    )
    noise = NoiseModel(
        NoiseConfig(
            odometry=OdometryConfig(
                radius_error_std=0.02, track_error_std=0.03, walk_std=0.005, yaw_walk_std=0.005
            ),
            imu=ImuConfig(gyro_std=0.005, bias_std=0.005, bias_walk_std=1e-4),
            pose_fix=fix_config,
        ),
        seed=seed,
    )
    odo = WheelOdometry(R, TRACK, noise.config.odometry, noise.odometry_rng)
    ekf = PoseEstimator()
    x = y = yaw = 0.0
    err_odo, err_ekf = [], []
    for k in range(1, int(duration / DT) + 1):
        t = k * DT
        v, w = 0.3 + 0.1 * math.sin(0.2 * t), 0.8 * math.sin(0.3 * t)
        x, y, yaw = arc_step(x, y, yaw, v, w, DT)
        ox, oy, _, ov, ow = odo.update(*wheel_speeds(v, w), DT)
        ekf.predict(t)
        ekf.update_odometry(ov, ow)
        ekf.update_gyro(noise.gyro(w, DT))
        fix = noise.pose_fix(t, (x, y, yaw))
        if fix is not None:
            ekf.update_pose_fix(*fix)
        ex, ey, _ = ekf.pose
        err_odo.append((ox - x) ** 2 + (oy - y) ** 2)
        err_ekf.append((ex - x) ** 2 + (ey - y) ** 2)
    return {"odo": math.sqrt(np.mean(err_odo)), "ekf": math.sqrt(np.mean(err_ekf))}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ekf_beats_dead_reckoning(seed: int) -> None:
    rmse = simulate(seed)
    assert rmse["ekf"] < 0.1  # bounded by the 1 Hz, 5 cm pose fixes
    assert rmse["ekf"] < 0.5 * rmse["odo"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ekf_without_pose_fix_still_beats_dead_reckoning(seed: int) -> None:
    """The gyro outweighs the track-error-biased odometry yaw rate."""
    rmse = simulate(seed, with_fix=False)
    assert rmse["ekf"] < rmse["odo"]


def test_ekf_tracks_velocity_from_odometry_and_gyro() -> None:
    ekf = PoseEstimator()
    for k in range(1, 31):
        ekf.predict(k * DT)
        ekf.update_odometry(0.3, 0.5)
        ekf.update_gyro(0.5)
    assert ekf.velocity == pytest.approx([0.3, 0.5], abs=1e-3)
    assert ekf.pose[2] == pytest.approx(0.5 * 3.0, abs=0.05)


def test_pose_fix_yaw_innovation_is_wrapped() -> None:
    ekf = PoseEstimator(EstimatorConfig(init_yaw_std=1.0), pose=(0.0, 0.0, math.pi - 0.01))
    for _ in range(20):
        ekf.update_pose_fix(0.0, 0.0, -math.pi + 0.01)
    # Pulled across +-pi (the short way), never through 0.
    assert angle_diff(ekf.pose[2], -math.pi + 0.01) < 0.005
    assert -math.pi <= ekf.pose[2] < math.pi


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda e, b: e.predict(b), "t"),
        (lambda e, b: e.update_odometry(b, 0.0), "v"),
        (lambda e, b: e.update_odometry(0.0, b), "w"),
        (lambda e, b: e.update_gyro(b), "w"),
        (lambda e, b: e.update_pose_fix(b, 0.0, 0.0), "x"),
        (lambda e, b: e.update_pose_fix(0.0, b, 0.0), "y"),
        (lambda e, b: e.update_pose_fix(0.0, 0.0, b), "yaw"),
        (lambda e, b: e.reset((0.0, 0.0, b), 0.0), "yaw"),
        (lambda e, b: e.reset((0.0, 0.0, 0.0), b), "t"),
    ],
)
def test_non_finite_input_raises_and_names_it(call, name: str, bad: float) -> None:
    ekf = PoseEstimator()
    before = ekf.state
    with pytest.raises(EstimatorError, match=rf"\b{name} = {bad!r}"):
        call(ekf, bad)
    assert np.array_equal(ekf.state, before)


def test_time_must_not_go_backwards() -> None:
    ekf = PoseEstimator(t=5.0)
    ekf.predict(5.0)  # equal time is fine
    ekf.predict(5.25)
    with pytest.raises(EstimatorError, match=r"5\.2.*5\.25"):
        ekf.predict(5.2)


def test_position_bound() -> None:
    with pytest.raises(EstimatorError, match="farther"):
        PoseEstimator().update_pose_fix(1e9, 0.0, 0.0)


def test_estimator_config_validation() -> None:
    with pytest.raises(ConfigError, match="gyro_std"):
        EstimatorConfig(gyro_std=-1.0)
    with pytest.raises(ConfigError, match="p_min"):
        EstimatorConfig(p_min=1.0, p_max=0.5)


def assert_healthy(ekf: PoseEstimator) -> None:
    cfg = ekf.config
    s, P = ekf.state, ekf.covariance
    assert np.isfinite(s).all() and np.isfinite(P).all()
    assert np.array_equal(P, P.T)
    eig = np.linalg.eigvalsh(P)
    assert eig.min() > 0 and eig.max() <= cfg.p_max * (1 + 1e-9)
    assert -math.pi <= s[2] < math.pi
    assert abs(s[3]) <= cfg.v_bound and abs(s[4]) <= cfg.w_bound


@pytest.mark.parametrize("seed", range(5))
def test_stays_finite_under_adversarial_inputs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    ekf = PoseEstimator()
    t = 0.0
    huge = [1e300, -1e300, 1e12, -1e12, 1e-300, 0.0, 5e-324]
    for _ in range(400):
        t += float(rng.choice([0.0, 1e-12, 0.1, 1e6, 1e-9]))
        ekf.predict(t)
        op = rng.integers(4)
        if op == 0:
            ekf.update_odometry(float(rng.choice(huge)), float(rng.choice(huge)))
        elif op == 1:
            ekf.update_gyro(float(rng.choice(huge)))
        elif op == 2:
            xy = rng.uniform(-1e4, 1e4, size=2) / math.sqrt(2)
            ekf.update_pose_fix(
                float(xy[0]), float(xy[1]), float(rng.choice([1e6, -1e6, 1e300, 3.14159]))
            )
        else:
            for _ in range(20):  # hammer one measurement: P shrinks towards its floor
                ekf.update_gyro(0.0)
        assert_healthy(ekf)


def test_long_gap_saturates_instead_of_diverging() -> None:
    ekf = PoseEstimator()
    ekf.update_odometry(10.0, 35.0)
    ekf.predict(1e15)
    assert_healthy(ekf)
    assert ekf.t == 1e15
