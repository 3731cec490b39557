"""Noise configuration: what each sensor, actuation and physics noise model does (docs/design/noise.md#noise-models).

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
#: What a dropped beam reads, per kind of ``LidarNoiseConfig.dropout_sector_kinds``.
SECTOR_DROPOUT_KINDS = ("nan", "pos_inf", "neg_inf", "zero", "out_of_range")
#: An ``out_of_range`` dropout reads this multiple of range_max: finite, beyond the limit, as
#: drivers that report their raw maximum do.
OUT_OF_RANGE_FACTOR = 2.0

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
#: Optional per-sector tables (default None: off). Profiles may omit them, and ``to_dict``
#: leaves them out while they are None, so configs without them serialise as before.
TABLE_PARAMS = {("lidar", "dropout_sector_scale"), ("lidar", "dropout_sector_kinds")}


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
    dropout_sector_scale: tuple[float, ...] | None = None
    """Optional (K,) factors on ``dropout_prob`` per angular sector: beam i of N falls in
    sector ``min(i * K // (N - 1), K - 1)``, K equal slices of the scan right to left (for the
    simulated 240 deg lidar, the observation's sectors). A sector's probability is
    ``min(1, dropout_prob * scale)``. None: every beam has ``dropout_prob``."""
    dropout_sector_kinds: tuple[tuple[float, ...], ...] | None = None
    """Optional (K, 5) proportions per sector of (NaN, +inf, -inf, 0.0, out of range) for
    dropped beams, each row summing to 1 (``SECTOR_DROPOUT_KINDS``; out of range reads
    ``OUT_OF_RANGE_FACTOR * range_max``). When set it replaces ``dropout_kinds``."""

    def __post_init__(self) -> None:
        _check_all(self, "lidar")
        self._check_tables()
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

    def _check_tables(self) -> None:
        scale, kinds = self.dropout_sector_scale, self.dropout_sector_kinds
        if scale is not None:
            try:
                values = tuple(float(v) for v in scale)
            except (TypeError, ValueError) as err:
                raise ConfigError(
                    f"lidar.dropout_sector_scale must be a list of numbers, got {scale!r}"
                ) from err
            if not values or not all(math.isfinite(v) and v >= 0 for v in values):
                raise ConfigError(
                    "lidar.dropout_sector_scale must be a non-empty list of finite numbers "
                    f">= 0, got {scale!r}"
                )
            object.__setattr__(self, "dropout_sector_scale", values)
        if kinds is not None:
            n = len(SECTOR_DROPOUT_KINDS)
            try:
                rows = tuple(tuple(float(v) for v in row) for row in kinds)
            except (TypeError, ValueError) as err:
                raise ConfigError(
                    f"lidar.dropout_sector_kinds must be a list of rows of {n} numbers, "
                    f"got {kinds!r}"
                ) from err
            for k, row in enumerate(rows):
                if (
                    len(row) != n
                    or any(not math.isfinite(v) or v < 0 or v > 1 for v in row)
                    or abs(sum(row) - 1.0) > KINDS_SUM_TOL
                ):
                    raise ConfigError(
                        f"lidar.dropout_sector_kinds[{k}] must be {n} proportions in [0, 1] "
                        f"summing to 1 ({', '.join(SECTOR_DROPOUT_KINDS)}), got {row!r}"
                    )
            if not rows:
                raise ConfigError("lidar.dropout_sector_kinds must have at least one row")
            if scale is not None and len(rows) != len(self.dropout_sector_scale or ()):
                raise ConfigError(
                    f"lidar.dropout_sector_kinds has {len(rows)} rows but "
                    f"lidar.dropout_sector_scale has {len(scale)} sectors"
                )
            object.__setattr__(self, "dropout_sector_kinds", rows)

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
        for group, name in sorted(TABLE_PARAMS):
            table = out[group][name]
            if table is None:
                del out[group][name]
            else:
                out[group][name] = [list(r) if isinstance(r, tuple) else r for r in table]
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
