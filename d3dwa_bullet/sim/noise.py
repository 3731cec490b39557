"""The noise of one episode: per-episode errors and seeded per-step random streams (docs/design/noise.md#noise-models).

A :class:`NoiseModel` samples what a :class:`~d3dwa_bullet.sim.noise_config.NoiseConfig`
asks for. Every model draws from its own ``numpy.random.Generator`` spawned from the
episode seed, so turning one model on never shifts another model's random stream. With
the default :class:`NoiseConfig`, every :class:`NoiseModel` method returns its input
unchanged, bit for bit, and draws nothing.

Wheel slip (longitudinal slip ratio ``s`` per wheel, 0 = grip, 1 = spinning in place):
the motor turns the wheel at the commanded speed, but the ground moves the robot at only
``(1 - s)`` of it. In the simulator the drive joint is therefore commanded
``omega_cmd * (1 - s)`` (:func:`ground_wheel_speed`), while the encoder, which counts
motor turns, reports ``joint_velocity / (1 - s)`` (:func:`encoder_wheel_speed`). Wheel
odometry thus *overestimates* motion under slip, as on a real robot.

This module is pure numpy: no PyBullet.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.geometry import wrap_angle_modular
from d3dwa_bullet.sim.noise_config import (
    OUT_OF_RANGE_FACTOR,
    SLIP_LEVEL_MAX,
    SLIP_STEP_MAX,
    LidarNoiseConfig,
    NoiseConfig,
)


@dataclass(frozen=True)
class PhysicsScales:
    """One episode's sampled physical scales (1.0 = nominal)."""

    friction: float = 1.0
    mass: float = 1.0
    torque: float = 1.0


def ground_wheel_speed(omega_cmd: np.ndarray | float, slip: np.ndarray | float) -> np.ndarray:
    """Wheel speed that actually moves the robot under slip: ``omega_cmd * (1 - s)``, rad/s.

    The simulator commands this to the wheel joint in physics.
    """
    return np.asarray(omega_cmd, dtype=np.float64) * (1.0 - np.asarray(slip, dtype=np.float64))


def encoder_wheel_speed(omega_joint: np.ndarray | float, slip: np.ndarray | float) -> np.ndarray:
    """What the encoder reports for a joint turning at ``omega_joint`` under slip ``s``, rad/s.

    ``omega_joint / (1 - s)``: the motor side turns faster than the ground speed, so
    odometry overestimates motion. ``s`` is at most 0.9, so this never divides by zero.
    """
    return np.asarray(omega_joint, dtype=np.float64) / (1.0 - np.asarray(slip, dtype=np.float64))


def beam_sector_index(n_beams: int, n_sectors: int) -> np.ndarray:
    """(n_beams,) int: beam i's sector, ``min(i * K // (N - 1), K - 1)`` (K equal slices of
    the scan, right to left; both end beams included, as the lidar casts them)."""
    i = np.arange(n_beams)
    return np.minimum(i * n_sectors // max(n_beams - 1, 1), n_sectors - 1)


def _sector_dropout(
    out: np.ndarray, lidar: LidarNoiseConfig, range_max: float, rng: np.random.Generator
) -> np.ndarray:
    """Dropout with per-sector probabilities and kinds; draws two values per beam, in the
    same order as the uniform dropout (which is used when neither table is set)."""
    n = out.size
    k = len(lidar.dropout_sector_scale or lidar.dropout_sector_kinds or ())
    sector = beam_sector_index(n, k)
    prob = np.full(n, lidar.dropout_prob)
    if lidar.dropout_sector_scale is not None:
        scale = np.asarray(lidar.dropout_sector_scale)
        prob = np.minimum(1.0, lidar.dropout_prob * scale[sector])
    drop = rng.random(n) < prob
    u = rng.random(n)
    if lidar.dropout_sector_kinds is None:
        kinds = np.array(
            [lidar.dropout_kinds[0], lidar.dropout_kinds[1], 0.0, lidar.dropout_kinds[2], 0.0]
        )
        table = np.broadcast_to(kinds, (k, kinds.size))
    else:
        table = np.asarray(lidar.dropout_sector_kinds)
    cum = np.cumsum(table, axis=1)[sector]  # (n, 5)
    kind = (u[:, None] >= cum).sum(axis=1)
    # As in the uniform case: u at or above a row's float sum goes to its last weighted kind.
    last = (table > 0).shape[1] - 1 - np.argmax((table > 0)[:, ::-1], axis=1)
    kind = np.minimum(kind, last[sector])
    values = np.array([np.nan, np.inf, -np.inf, 0.0, OUT_OF_RANGE_FACTOR * range_max])
    out[drop] = values[kind[drop]]
    return out


#: Names of the independent random streams, in spawn order. Append only: reordering would
#: change every episode of every existing seed.
STREAMS = (
    "slip",
    "lidar_range",
    "lidar_dropout",
    "lidar_spurious",
    "odometry",
    "imu",
    "pose_fix",
    "physics",
)


class NoiseModel:
    """The noise state of one episode: sampled per-episode errors plus per-stream RNGs.

    config: what to corrupt. seed: the episode seed (int) or a SeedSequence derived from it.
    Each model owns one stream (``STREAMS``); a model that is off never draws.
    """

    def __init__(self, config: NoiseConfig = NoiseConfig(), seed: int | np.random.SeedSequence = 0):
        if not isinstance(config, NoiseConfig):
            raise ConfigError(f"NoiseModel needs a NoiseConfig, got {config!r}")
        if isinstance(seed, bool) or not isinstance(
            seed, int | np.integer | np.random.SeedSequence
        ):
            raise ConfigError(f"NoiseModel seed must be an int or SeedSequence, got {seed!r}")
        self.config = config
        root = (
            seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
        )
        children = root.spawn(len(STREAMS))
        self.rngs: dict[str, np.random.Generator] = {
            name: np.random.Generator(np.random.PCG64(child))
            for name, child in zip(STREAMS, children, strict=True)
        }

        slip = config.slip
        self.slip_level = np.zeros(2)
        """(2,) per-episode slip ratio of the (left, right) wheel."""
        if slip.enabled:
            draw = self.rngs["slip"].normal(slip.level_mean, slip.level_std, size=2)
            self.slip_level = np.clip(np.abs(draw), 0.0, SLIP_LEVEL_MAX)

        imu = config.imu
        self.gyro_bias = 0.0
        """Current gyro bias, rad/s."""
        if imu.enabled:
            self.gyro_bias = float(self.rngs["imu"].normal(0.0, imu.bias_std))

        phys = config.physics
        self.physics = PhysicsScales()
        """This episode's sampled physical scales."""
        if phys.enabled:
            u = self.rngs["physics"].random(3)
            ranges = (phys.friction_scale_range, phys.mass_scale_range, phys.torque_scale_range)
            f, m, t = (
                lo + (hi - lo) * ui if hi > lo else lo
                for (lo, hi), ui in zip(ranges, u, strict=True)
            )
            self.physics = PhysicsScales(friction=float(f), mass=float(m), torque=float(t))

        self._queue: deque[tuple[float, float]] = deque(
            [(0.0, 0.0)] * config.latency.steps, maxlen=config.latency.steps + 1
        )
        self._next_fix = 0

    @property
    def odometry_rng(self) -> np.random.Generator:
        """The odometry stream, for :class:`d3dwa_bullet.sim.odometry.WheelOdometry`."""
        return self.rngs["odometry"]

    @property
    def friction_scale(self) -> float:
        return self.physics.friction

    @property
    def mass_scale(self) -> float:
        return self.physics.mass

    @property
    def torque_scale(self) -> float:
        return self.physics.torque

    def wheel_slip_ratio(self) -> np.ndarray:
        """This control step's slip ratio of the (left, right) wheel: (2,) float64 in [0, 0.9]."""
        slip = self.config.slip
        if not slip.enabled:
            return np.zeros(2)
        step = self.rngs["slip"].normal(0.0, slip.step_std, size=2)
        return np.clip(self.slip_level + step, 0.0, SLIP_STEP_MAX)

    def corrupt_ranges(self, ranges: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
        """A corrupted copy of one scan's ranges: (N,) float64, m.

        In order: Gaussian noise on valid returns (finite, > 0, in [range_min, range_max]),
        clipped back into [range_min, range_max] so noise alone never invalidates a beam;
        phantom returns uniform in [spurious_min, spurious_max] on any beam; dropout to
        NaN / +inf / 0.0 in ``dropout_kinds`` proportions (with the optional per-sector
        tables, per-sector probabilities and NaN / +inf / -inf / 0.0 / out-of-range kinds).
        Each part draws a fixed number of values per beam from its own stream, whatever the
        ranges are.
        """
        out = np.array(ranges, dtype=np.float64, copy=True)
        if out.ndim != 1:
            raise ConfigError(f"corrupt_ranges needs a 1-D ranges array, got shape {out.shape}")
        lidar = self.config.lidar
        n = out.size
        if lidar.range_std > 0:
            noise = self.rngs["lidar_range"].normal(0.0, lidar.range_std, size=n)
            with np.errstate(invalid="ignore"):
                valid = np.isfinite(out) & (out > 0) & (out >= range_min) & (out <= range_max)
            out[valid] = np.clip(out[valid] + noise[valid], range_min, range_max)
        if lidar.spurious_prob > 0:
            rng = self.rngs["lidar_spurious"]
            hit = rng.random(n) < lidar.spurious_prob
            value = rng.uniform(lidar.spurious_min, lidar.spurious_max, size=n)
            out[hit] = value[hit]
        if lidar.dropout_prob > 0 and (
            lidar.dropout_sector_scale is not None or lidar.dropout_sector_kinds is not None
        ):
            out = _sector_dropout(out, lidar, range_max, self.rngs["lidar_dropout"])
        elif lidar.dropout_prob > 0:
            rng = self.rngs["lidar_dropout"]
            drop = rng.random(n) < lidar.dropout_prob
            kind = np.searchsorted(np.cumsum(lidar.dropout_kinds), rng.random(n), side="right")
            # The cumulative sum may end a hair below 1 in floating point: send u >= it to the
            # last kind that has any weight.
            last = max(i for i, p in enumerate(lidar.dropout_kinds) if p > 0)
            kind = np.minimum(kind, last)
            out[drop] = np.array([np.nan, np.inf, 0.0])[kind[drop]]
        return out

    def gyro(self, w_true: float, dt: float) -> float:
        """Gyro yaw-rate reading for true rate ``w_true`` (rad/s); ``dt`` (s) since the last call
        advances the bias random walk."""
        imu = self.config.imu
        if not imu.enabled:
            return w_true
        if not (math.isfinite(dt) and dt >= 0):
            raise ConfigError(f"gyro: dt must be finite and >= 0, got {dt!r}")
        rng = self.rngs["imu"]
        walk, white = rng.normal(0.0, 1.0, size=2)
        self.gyro_bias += imu.bias_walk_std * math.sqrt(dt) * float(walk)
        return float(w_true) + self.gyro_bias + imu.gyro_std * float(white)

    def delay(self, command: tuple[float, float]) -> tuple[float, float]:
        """The command to apply now, given the one issued now: the one issued ``steps`` calls
        ago, or (0, 0) until that many have been issued. Call once per control step."""
        if self.config.latency.steps == 0:
            return command
        self._queue.append(command)
        return self._queue.popleft()

    def pose_fix(
        self, t: float, true_pose: tuple[float, float, float] | np.ndarray
    ) -> tuple[float, float, float] | None:
        """A noisy absolute pose (x, y, yaw) when one is due at time ``t`` (s), else None.

        Fixes are due at t = k / rate_hz, k = 0, 1, ...; a call at or after a due time
        delivers one fix (late calls do not queue several). A due fix is dropped with
        ``dropout_prob``. Always None when the rate is 0.
        """
        fix = self.config.pose_fix
        if not fix.enabled:
            return None
        if not math.isfinite(t):
            raise ConfigError(f"pose_fix: t must be finite, got {t!r}")
        # Tolerance: control times built by repeated addition of 0.1 s land a hair early.
        k = math.floor(t * fix.rate_hz + 1e-6)
        if k < self._next_fix:
            return None
        self._next_fix = k + 1
        rng = self.rngs["pose_fix"]
        u = rng.random()
        e = rng.normal(0.0, 1.0, size=3)
        if u < fix.dropout_prob:
            return None
        x, y, yaw = (float(v) for v in true_pose)
        return (
            x + fix.pos_std * float(e[0]),
            y + fix.pos_std * float(e[1]),
            wrap_angle_modular(yaw + fix.yaw_std * float(e[2])),
        )
