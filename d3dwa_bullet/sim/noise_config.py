"""Noise configuration: what each sensor, actuation and physics noise model does (docs/design.md#noise-models).

Every model is configured by a frozen dataclass whose defaults switch it off; a
:class:`NoiseConfig` holds one of each. Values are checked against ``PARAM_DOMAINS``
(which the randomisation profiles check against too), and a config converts to and from a
plain nested dict for YAML and JSON. :mod:`~d3dwa_bullet.sim.noise` draws the noise.

This module is pure numpy: no PyBullet.
"""

from __future__ import annotations

import math
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
