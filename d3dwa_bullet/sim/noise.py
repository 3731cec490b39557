"""Sensor, actuation and physics noise models for sim-to-real training (SPEC section 7).

Every model is configured by a frozen dataclass whose defaults switch it off, and draws
from its own ``numpy.random.Generator`` spawned from the episode seed, so turning one
model on never shifts another model's random stream. With the default
:class:`NoiseConfig`, every :class:`NoiseModel` method returns its input unchanged, bit
for bit, and draws nothing.

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
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError

#: Slip ratio limits: per-episode level, then level plus per-step variation.
SLIP_LEVEL_MAX = 0.5
SLIP_STEP_MAX = 0.9
#: Tolerance on the sum of the dropout kind proportions.
KINDS_SUM_TOL = 1e-6

#: Valid domain of every scalar parameter, ``group -> field -> (lo, hi)`` (inclusive).
#: The dataclasses below and the randomisation profiles both check against it.
PARAM_DOMAINS: dict[str, dict[str, tuple[float, float]]] = {
    "slip": {
        "level_mean": (0.0, SLIP_LEVEL_MAX),
        "level_std": (0.0, math.inf),
        "step_std": (0.0, math.inf),
    },
    "lidar": {
        "range_std": (0.0, math.inf),
        "dropout_prob": (0.0, 1.0),
        "spurious_prob": (0.0, 1.0),
        "spurious_min": (0.0, math.inf),
        "spurious_max": (0.0, math.inf),
    },
    "odometry": {
        "radius_error_std": (0.0, math.inf),
        "track_error_std": (0.0, math.inf),
        "walk_std": (0.0, math.inf),
        "yaw_walk_std": (0.0, math.inf),
    },
    "imu": {
        "gyro_std": (0.0, math.inf),
        "bias_std": (0.0, math.inf),
        "bias_walk_std": (0.0, math.inf),
    },
    "latency": {"steps": (0, 1000)},
    "pose_fix": {
        "rate_hz": (0.0, math.inf),
        "pos_std": (0.0, math.inf),
        "yaw_std": (0.0, math.inf),
        "dropout_prob": (0.0, 1.0),
    },
}
#: Integer-valued parameters.
INT_PARAMS = {("latency", "steps")}
#: Parameters that are tuples: ``group -> field -> length``.
TUPLE_PARAMS: dict[str, dict[str, int]] = {
    "lidar": {"dropout_kinds": 3},
    "physics": {"friction_scale_range": 2, "mass_scale_range": 2, "torque_scale_range": 2},
}


def check_param(group: str, name: str, value: Any) -> None:
    """Raise ConfigError unless ``value`` is in the domain of scalar parameter group.name."""
    lo, hi = PARAM_DOMAINS[group][name]
    where = f"{group}.{name}"
    if (group, name) in INT_PARAMS:
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise ConfigError(f"{where} must be an integer, got {value!r}")
    elif isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ConfigError(f"{where} must be a number, got {value!r}")
    if not (math.isfinite(value) and lo <= value <= hi):
        raise ConfigError(f"{where} must be finite and in [{lo}, {hi}], got {value!r}")


def _check_all(obj: Any, group: str) -> None:
    for name in PARAM_DOMAINS.get(group, {}):
        check_param(group, name, getattr(obj, name))


def _as_float_tuple(group: str, name: str, value: Any, n: int) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{group}.{name} must be {n} numbers, got {value!r}") from err
    if len(out) != n or not all(math.isfinite(v) for v in out):
        raise ConfigError(f"{group}.{name} must be {n} finite numbers, got {value!r}")
    return out


@dataclass(frozen=True)
class SlipConfig:
    """Longitudinal wheel slip. Per episode each wheel gets a level ``|N(mean, std)|``
    clipped to [0, 0.5]; each control step adds ``N(0, step_std)``, clipped to [0, 0.9]."""

    level_mean: float = 0.0
    """Mean per-episode slip ratio, dimensionless in [0, 0.5]."""
    level_std: float = 0.0
    """Spread of the per-episode slip ratio between episodes and wheels."""
    step_std: float = 0.0
    """Per-control-step variation of the slip ratio (floor texture, bumps)."""

    def __post_init__(self) -> None:
        _check_all(self, "slip")

    @property
    def enabled(self) -> bool:
        return self.level_mean > 0 or self.level_std > 0 or self.step_std > 0


@dataclass(frozen=True)
class LidarNoiseConfig:
    """2D lidar corruption: range noise, beam dropout, spurious short returns."""

    range_std: float = 0.0
    """Gaussian noise on valid returns, m (result clipped to [range_min, range_max])."""
    dropout_prob: float = 0.0
    """Probability that a beam is dropped, per beam and scan."""
    dropout_kinds: tuple[float, float, float] = (0.0, 1.0, 0.0)
    """Proportions of dropped beams reported as (NaN, +inf, 0.0); must sum to 1. The default
    is REP-117's "no return" (+inf) only."""
    spurious_prob: float = 0.0
    """Probability that a beam reports a phantom short return (dust, reflections)."""
    spurious_min: float = 0.05
    """Lower end of the uniform phantom range, m."""
    spurious_max: float = 0.5
    """Upper end of the uniform phantom range, m."""

    def __post_init__(self) -> None:
        _check_all(self, "lidar")
        kinds = _as_float_tuple("lidar", "dropout_kinds", self.dropout_kinds, 3)
        if any(k < 0 or k > 1 for k in kinds) or abs(sum(kinds) - 1.0) > KINDS_SUM_TOL:
            raise ConfigError(
                f"lidar.dropout_kinds must be 3 proportions in [0, 1] summing to 1, got {kinds!r}"
            )
        object.__setattr__(self, "dropout_kinds", kinds)
        if self.spurious_min > self.spurious_max:
            raise ConfigError(
                f"lidar.spurious_min = {self.spurious_min!r} must be <= "
                f"lidar.spurious_max = {self.spurious_max!r}"
            )

    @property
    def enabled(self) -> bool:
        return self.range_std > 0 or self.dropout_prob > 0 or self.spurious_prob > 0


@dataclass(frozen=True)
class OdometryConfig:
    """Wheel odometry errors: systematic per-episode geometry errors plus a random walk."""

    radius_error_std: float = 0.0
    """Std of each wheel's believed/true radius scale minus 1 (0.01 = 1 %)."""
    track_error_std: float = 0.0
    """Std of the believed/true track scale minus 1."""
    walk_std: float = 0.0
    """Random walk on the integrated x and y, m per sqrt(s)."""
    yaw_walk_std: float = 0.0
    """Random walk on the integrated yaw, rad per sqrt(s)."""

    def __post_init__(self) -> None:
        _check_all(self, "odometry")

    @property
    def enabled(self) -> bool:
        return any(getattr(self, f.name) > 0 for f in fields(self))


@dataclass(frozen=True)
class ImuConfig:
    """Yaw-rate gyro: white noise plus a bias that starts random and wanders."""

    gyro_std: float = 0.0
    """White noise per sample, rad/s."""
    bias_std: float = 0.0
    """Std of the per-episode initial bias, rad/s."""
    bias_walk_std: float = 0.0
    """Random walk of the bias, rad/s per sqrt(s)."""

    def __post_init__(self) -> None:
        _check_all(self, "imu")

    @property
    def enabled(self) -> bool:
        return self.gyro_std > 0 or self.bias_std > 0 or self.bias_walk_std > 0


@dataclass(frozen=True)
class LatencyConfig:
    """Actuation latency: a command is applied ``steps`` control steps after it is issued."""

    steps: int = 0
    """Delay in control steps (0 = none)."""

    def __post_init__(self) -> None:
        _check_all(self, "latency")

    @property
    def enabled(self) -> bool:
        return self.steps > 0


@dataclass(frozen=True)
class PhysicsConfig:
    """Per-episode physical randomisation: each scale is drawn uniformly from its (lo, hi)."""

    friction_scale_range: tuple[float, float] = (1.0, 1.0)
    """Multiplier on the wheel/ground lateral and rolling friction."""
    mass_scale_range: tuple[float, float] = (1.0, 1.0)
    """Multiplier on the base mass (payload)."""
    torque_scale_range: tuple[float, float] = (1.0, 1.0)
    """Multiplier on the wheel motors' maximum torque."""

    def __post_init__(self) -> None:
        for f in fields(self):
            lo, hi = _as_float_tuple("physics", f.name, getattr(self, f.name), 2)
            if not 0 < lo <= hi:
                raise ConfigError(
                    f"physics.{f.name} must be (lo, hi) with 0 < lo <= hi, got {(lo, hi)!r}"
                )
            object.__setattr__(self, f.name, (lo, hi))

    @property
    def enabled(self) -> bool:
        return any(getattr(self, f.name) != (1.0, 1.0) for f in fields(self))


@dataclass(frozen=True)
class PhysicsScales:
    """One episode's sampled physical scales (1.0 = nominal)."""

    friction: float = 1.0
    mass: float = 1.0
    torque: float = 1.0


@dataclass(frozen=True)
class PoseFixConfig:
    """Low-rate noisy absolute pose (stand-in for the robot's own map localisation)."""

    rate_hz: float = 0.0
    """Fix rate, Hz (0 = off)."""
    pos_std: float = 0.0
    """Gaussian noise on x and y, m."""
    yaw_std: float = 0.0
    """Gaussian noise on yaw, rad."""
    dropout_prob: float = 0.0
    """Probability that a scheduled fix is missing (localisation lost / late)."""

    def __post_init__(self) -> None:
        _check_all(self, "pose_fix")

    @property
    def enabled(self) -> bool:
        return self.rate_hz > 0


#: NoiseConfig's groups and their dataclasses, in field (and sampling) order.
CONFIG_GROUPS: dict[str, type] = {
    "slip": SlipConfig,
    "lidar": LidarNoiseConfig,
    "odometry": OdometryConfig,
    "imu": ImuConfig,
    "latency": LatencyConfig,
    "physics": PhysicsConfig,
    "pose_fix": PoseFixConfig,
}


@dataclass(frozen=True)
class NoiseConfig:
    """Every noise model of one episode. The default is noise-free."""

    slip: SlipConfig = field(default_factory=SlipConfig)
    lidar: LidarNoiseConfig = field(default_factory=LidarNoiseConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    imu: ImuConfig = field(default_factory=ImuConfig)
    latency: LatencyConfig = field(default_factory=LatencyConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    pose_fix: PoseFixConfig = field(default_factory=PoseFixConfig)

    def __post_init__(self) -> None:
        for name, cls in CONFIG_GROUPS.items():
            if not isinstance(getattr(self, name), cls):
                raise ConfigError(
                    f"NoiseConfig.{name} must be a {cls.__name__}, got {getattr(self, name)!r}"
                )

    @property
    def enabled(self) -> bool:
        """True if any model is on (the robot then has to rely on its estimator)."""
        return any(getattr(self, name).enabled for name in CONFIG_GROUPS)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict (tuples as lists), YAML/JSON friendly."""
        out = asdict(self)
        for group, tuples in TUPLE_PARAMS.items():
            for name in tuples:
                out[group][name] = list(out[group][name])
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> NoiseConfig:
        """Inverse of :meth:`to_dict`. Missing groups/fields keep their (off) defaults."""
        if not isinstance(data, Mapping):
            raise ConfigError(f"NoiseConfig.from_dict needs a mapping, got {data!r}")
        unknown = set(data) - set(CONFIG_GROUPS)
        if unknown:
            raise ConfigError(
                f"NoiseConfig: unknown group(s) {sorted(unknown)}; known {list(CONFIG_GROUPS)}"
            )
        groups = {}
        for name, sub in data.items():
            group_cls = CONFIG_GROUPS[name]
            if not isinstance(sub, Mapping):
                raise ConfigError(f"NoiseConfig.{name} must be a mapping, got {sub!r}")
            known = {f.name for f in fields(group_cls)}
            bad = set(sub) - known
            if bad:
                raise ConfigError(
                    f"NoiseConfig.{name}: unknown field(s) {sorted(bad)}; known {sorted(known)}"
                )
            values = {k: tuple(v) if isinstance(v, list) else v for k, v in sub.items()}
            groups[name] = group_cls(**values)
        return cls(**groups)


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


def wrap_angle(a: float) -> float:
    """Angle wrapped to [-pi, pi), rad."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


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
        """The odometry stream, for :class:`d3dwa_bullet.odometry.WheelOdometry`."""
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
        NaN / +inf / 0.0 in ``dropout_kinds`` proportions. Each part draws a fixed number
        of values per beam from its own stream, whatever the ranges are.
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
        if lidar.dropout_prob > 0:
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
            wrap_angle(yaw + fix.yaw_std * float(e[2])),
        )
