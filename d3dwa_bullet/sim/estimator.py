"""Pose and velocity estimation: an EKF over [x, y, yaw, v, w] (docs/design/noise.md#estimator).

Prediction is the unicycle model under constant (v, w), integrated exactly along the arc
(:func:`~d3dwa_bullet.geometry.arc_step`) with its analytic Jacobian; process noise is
white acceleration on v and w plus a small position/heading random walk for what the
model misses (slip, bumps). Updates: wheel-odometry velocities (v, w), gyro (w), and a
low-rate absolute pose fix (x, y, yaw) whose yaw innovation is wrapped to [-pi, pi).

Robustness, so the planner never sees NaN: every input must be finite
(:class:`EstimatorError` otherwise); velocity readings are saturated to physical bounds
(as a real gyro saturates at its full-scale range); positions farther than
``position_bound`` are rejected; one prediction integrates at most ``max_predict_dt``
(constant-velocity extrapolation over a longer gap is meaningless: the covariance saturates
instead and the next measurements take over); after every step P is symmetrised and its
eigenvalues clipped to [p_min, p_max], and the state and P are checked to be finite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numba
import numpy as np
import scipy.linalg
from filterpy.kalman import ExtendedKalmanFilter
from numpy import dot

from d3dwa_bullet.errors import ConfigError, EstimatorError
from d3dwa_bullet.geometry import arc_step, wrap_angle_modular

X, Y, YAW, V, W = range(5)
_H_ODOM = np.zeros((2, 5))
_H_ODOM[0, V] = _H_ODOM[1, W] = 1.0
_H_GYRO = np.zeros((1, 5))
_H_GYRO[0, W] = 1.0
_H_FIX = np.zeros((3, 5))
_H_FIX[0, X] = _H_FIX[1, Y] = _H_FIX[2, YAW] = 1.0


@dataclass(frozen=True)
class EstimatorConfig:
    """EKF noise and safety bounds. Defaults suit Kachaka at 10 Hz with the `real` profile."""

    accel_density: float = 0.1
    """White-acceleration spectral density on v, (m/s^2)^2 s: a 0.1 s step lets v move ~0.1 m/s."""
    alpha_density: float = 0.4
    """White angular-acceleration spectral density on w, (rad/s^2)^2 s."""
    pos_density: float = 1e-4
    """Random walk density on x and y, m^2/s (slip, unmodelled motion)."""
    yaw_density: float = 1e-4
    """Random walk density on yaw, rad^2/s."""
    odom_v_std: float = 0.02
    """Wheel-odometry v measurement std, m/s (calibration error and slip)."""
    odom_w_std: float = 0.05
    """Wheel-odometry w measurement std, rad/s (track error and slip hit w hardest)."""
    gyro_std: float = 0.01
    """Gyro w measurement std, rad/s (white noise plus an unmodelled bias of similar size)."""
    fix_pos_std: float = 0.05
    """Pose-fix x, y std, m."""
    fix_yaw_std: float = 0.05
    """Pose-fix yaw std, rad."""
    init_pos_std: float = 0.01
    """Initial x, y std after reset, m."""
    init_yaw_std: float = 0.01
    """Initial yaw std after reset, rad."""
    init_vel_std: float = 0.1
    """Initial v (m/s) and w (rad/s) std after reset."""
    v_bound: float = 10.0
    """|v| saturation for readings and state, m/s (25x Kachaka's top speed)."""
    w_bound: float = 35.0
    """|w| saturation, rad/s (a 2000 deg/s MEMS gyro's full scale)."""
    position_bound: float = 1e4
    """Pose fixes and resets farther than this from the origin are a caller bug, m."""
    max_predict_dt: float = 1.0
    """Longest time one prediction integrates, s."""
    p_min: float = 1e-12
    """Floor on the eigenvalues of P (keeps it positive definite)."""
    p_max: float = 1e6
    """Ceiling on the eigenvalues of P (keeps it bounded)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ConfigError(
                    f"EstimatorConfig.{f.name} must be a positive number, got {value!r}"
                )
        if self.p_min >= self.p_max:
            raise ConfigError(
                f"EstimatorConfig needs p_min < p_max, got {self.p_min!r}, {self.p_max!r}"
            )


class _UnicycleEKF(ExtendedKalmanFilter):
    """filterpy's EKF with the nonlinear unicycle prediction of the mean.

    ``predict`` and ``update`` are filterpy's own equations, the same numpy and SciPy calls in
    the same order (so every estimate is bit-identical), without what this filter never
    reads: the prior and posterior copies, the deep copy of z and the argument checks. They
    were a third of the filter's time (docs/design/noise.md#estimator)."""

    dt: float = 0.0

    def predict_x(self, u: object = 0) -> None:
        x, y, yaw, v, w = self.x[:, 0]
        nx, ny, nyaw = arc_step(x, y, yaw, v, w, self.dt)
        self.x = np.array([[nx], [ny], [wrap_angle_modular(nyaw)], [v], [w]])

    def predict(self, u: object = 0) -> None:
        self.predict_x(u)
        self.P = dot(self.F, self.P).dot(self.F.T) + self.Q

    def update(self, z, HJacobian, Hx, R=None, args=(), hx_args=(), residual=np.subtract):  # type: ignore[no-untyped-def]
        H = HJacobian(self.x, *args)
        PHT = dot(self.P, H.T)
        self.S = dot(H, PHT) + R
        # a 1x1 inverse (the gyro's) is one division, the bits SciPy's inverse gives too
        self.SI = 1.0 / self.S if self.S.shape == (1, 1) else scipy.linalg.inv(self.S)
        self.K = PHT.dot(self.SI)
        hx = Hx(self.x, *hx_args)
        self.y = residual(z, hx)
        self.x = self.x + dot(self.K, self.y)
        I_KH = self._I - dot(self.K, H)
        self.P = dot(I_KH, self.P).dot(I_KH.T) + dot(self.K, R).dot(self.K.T)


@numba.njit(cache=True, nogil=True)
def _eigenvalues_inside(P: np.ndarray, low: float, high: float) -> bool:
    """True only if every eigenvalue of the symmetric P lies in (low, high) with a margin far
    above rounding, proven without an eigendecomposition: the largest is at most the largest
    absolute row sum (Gershgorin), and P - (low + margin) I has a Cholesky factor. False
    means "not proven" (the caller then decomposes); it is never True for a P that
    ``numpy.linalg.eigh`` would find outside the bounds."""
    n = P.shape[0]
    scale = 0.0
    row_max = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += abs(P[i, j])
        row_max = max(row_max, row)
        scale = max(scale, abs(P[i, i]))
    margin = 1e3 * n * 2.220446049250313e-16 * scale
    if not row_max < high - margin:
        return False
    shift = low + margin
    L = np.zeros((n, n))
    for j in range(n):
        d = P[j, j] - shift
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            e = P[i, j]
            for k in range(j):
                e -= L[i, k] * L[j, k]
            L[i, j] = e / L[j, j]
    return True


def unicycle_jacobian(state: np.ndarray, dt: float) -> np.ndarray:
    """d(arc_step)/d(state) for state [x, y, yaw, v, w]: (5, 5)."""
    _, _, yaw, v, w = (float(s) for s in state)
    a = 0.5 * w * dt
    if abs(a) > 1e-4:
        sinc = math.sin(a) / a
        dsinc = (a * math.cos(a) - math.sin(a)) / (a * a)
    else:  # Taylor series: the closed forms lose all precision near a = 0
        sinc = 1.0 - a * a / 6.0
        dsinc = -a / 3.0 + a**3 / 30.0
    chord = v * dt * sinc
    dchord_dw = v * dt * dsinc * 0.5 * dt
    mid = yaw + a
    c, s = math.cos(mid), math.sin(mid)
    F = np.eye(5)
    F[X, YAW] = -chord * s
    F[Y, YAW] = chord * c
    F[X, V] = dt * sinc * c
    F[Y, V] = dt * sinc * s
    F[X, W] = dchord_dw * c - chord * s * 0.5 * dt
    F[Y, W] = dchord_dw * s + chord * c * 0.5 * dt
    F[YAW, W] = dt
    return F


def _residual_fix(z: np.ndarray, hx: np.ndarray) -> np.ndarray:
    r = z - hx
    r[2, 0] = wrap_angle_modular(float(r[2, 0]))
    return r


class PoseEstimator:
    """EKF over [x, y, yaw, v, w] (m, m, rad, m/s, rad/s) in the odometry/world frame.

    Per control step: ``predict(t)``, then any of ``update_odometry``, ``update_gyro``,
    ``update_pose_fix`` for the readings taken at t. Read ``pose`` / ``velocity`` after.
    """

    def __init__(
        self,
        config: EstimatorConfig = EstimatorConfig(),
        pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        t: float = 0.0,
    ):
        self.config = config
        self._ekf = _UnicycleEKF(dim_x=5, dim_z=2)
        self._r_odom = np.diag([config.odom_v_std**2, config.odom_w_std**2])
        self._r_gyro = np.array([[config.gyro_std**2]])
        self._r_fix = np.diag([config.fix_pos_std**2, config.fix_pos_std**2, config.fix_yaw_std**2])
        self.t = 0.0
        self.reset(pose, t)

    def reset(
        self, pose: tuple[float, float, float], t: float, velocity: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        """Restart at pose (x, y, yaw) and velocity (v, w) at time t (s), with the initial P."""
        x, y, yaw = self._positions("reset", pose)
        v, w = (
            self._finite("reset", name, val) for name, val in zip(("v", "w"), velocity, strict=True)
        )
        self.t = self._finite("reset", "t", t)
        cfg = self.config
        self._ekf.x = np.array(
            [[x], [y], [wrap_angle_modular(yaw)], [self._sat_v(v)], [self._sat_w(w)]]
        )
        self._ekf.P = np.diag(
            [
                cfg.init_pos_std**2,
                cfg.init_pos_std**2,
                cfg.init_yaw_std**2,
                cfg.init_vel_std**2,
                cfg.init_vel_std**2,
            ]
        )

    @property
    def state(self) -> np.ndarray:
        """[x, y, yaw, v, w]: (5,) float64 copy."""
        return self._ekf.x[:, 0].copy()

    @property
    def covariance(self) -> np.ndarray:
        """P: (5, 5) float64 copy."""
        return self._ekf.P.copy()

    @property
    def pose(self) -> np.ndarray:
        """(x, y, yaw): (3,) float64, m/rad, yaw in [-pi, pi)."""
        return self._ekf.x[:3, 0].copy()

    @property
    def velocity(self) -> np.ndarray:
        """(v, w): (2,) float64, m/s, rad/s."""
        return self._ekf.x[3:, 0].copy()

    def predict(self, t: float) -> None:
        """Propagate to time t (s). t must not go back in time; equal t is a no-op."""
        t = self._finite("predict", "t", t)
        if t < self.t:
            raise EstimatorError(
                f"predict: time went backwards, t = {t!r} s < last t = {self.t!r} s"
            )
        dt = min(t - self.t, self.config.max_predict_dt)
        self.t = t
        if dt == 0.0:
            return
        cfg = self.config
        ekf = self._ekf
        ekf.dt = dt
        ekf.F = unicycle_jacobian(ekf.x[:, 0], dt)
        ekf.Q = np.diag(
            [
                cfg.pos_density * dt,
                cfg.pos_density * dt,
                cfg.yaw_density * dt,
                cfg.accel_density * dt,
                cfg.alpha_density * dt,
            ]
        )
        ekf.predict()
        self._sanitise("predict")

    def update_odometry(self, v: float, w: float) -> None:
        """Fuse wheel-odometry body velocities v (m/s), w (rad/s)."""
        v = self._sat_v(self._finite("update_odometry", "v", v))
        w = self._sat_w(self._finite("update_odometry", "w", w))
        self._ekf.update(
            np.array([[v], [w]]), lambda _: _H_ODOM, lambda s: _H_ODOM @ s, R=self._r_odom
        )
        self._sanitise("update_odometry")

    def update_gyro(self, w: float) -> None:
        """Fuse a gyro yaw rate w (rad/s)."""
        w = self._sat_w(self._finite("update_gyro", "w", w))
        self._ekf.update(np.array([[w]]), lambda _: _H_GYRO, lambda s: _H_GYRO @ s, R=self._r_gyro)
        self._sanitise("update_gyro")

    def update_pose_fix(self, x: float, y: float, yaw: float) -> None:
        """Fuse an absolute pose fix (x, y, yaw), m/rad; the yaw innovation is wrapped."""
        x, y, yaw = self._positions("update_pose_fix", (x, y, yaw))
        self._ekf.update(
            np.array([[x], [y], [wrap_angle_modular(yaw)]]),
            lambda _: _H_FIX,
            lambda s: _H_FIX @ s,
            R=self._r_fix,
            residual=_residual_fix,
        )
        self._sanitise("update_pose_fix")

    @staticmethod
    def _finite(where: str, name: str, value: float) -> float:
        try:
            out = float(value)
        except (TypeError, ValueError) as err:
            raise EstimatorError(f"{where}: {name} = {value!r} is not a number") from err
        if not math.isfinite(out):
            raise EstimatorError(f"{where}: {name} = {out!r} is not finite")
        return out

    def _positions(
        self, where: str, pose: tuple[float, float, float]
    ) -> tuple[float, float, float]:
        if len(pose) != 3:
            raise EstimatorError(f"{where}: pose must be (x, y, yaw), got {pose!r}")
        x, y, yaw = (
            self._finite(where, name, v) for name, v in zip(("x", "y", "yaw"), pose, strict=True)
        )
        bound = self.config.position_bound
        if math.hypot(x, y) > bound:
            raise EstimatorError(
                f"{where}: position ({x!r}, {y!r}) is farther than {bound} m from the origin"
            )
        return x, y, yaw

    def _sat_v(self, v: float) -> float:
        return min(max(v, -self.config.v_bound), self.config.v_bound)

    def _sat_w(self, w: float) -> float:
        return min(max(w, -self.config.w_bound), self.config.w_bound)

    def _sanitise(self, where: str) -> None:
        ekf = self._ekf
        cfg = self.config
        if not (np.isfinite(ekf.x).all() and np.isfinite(ekf.P).all()):
            raise EstimatorError(f"{where}: filter diverged (state {ekf.x[:, 0].tolist()})")
        ekf.x[YAW, 0] = wrap_angle_modular(float(ekf.x[YAW, 0]))
        ekf.x[V, 0] = self._sat_v(float(ekf.x[V, 0]))
        ekf.x[W, 0] = self._sat_w(float(ekf.x[W, 0]))
        P = 0.5 * (ekf.P + ekf.P.T)
        if not _eigenvalues_inside(P, cfg.p_min, cfg.p_max):  # proven inside: nothing to clip
            vals, vecs = np.linalg.eigh(P)
            if vals.min() < cfg.p_min or vals.max() > cfg.p_max:
                P = (vecs * np.clip(vals, cfg.p_min, cfg.p_max)) @ vecs.T
                P = 0.5 * (P + P.T)
        ekf.P = P
