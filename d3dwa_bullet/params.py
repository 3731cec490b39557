"""Parameter sets, as frozen dataclasses whose defaults are the paper's Table "Parameter values".

Units are SI throughout (m, s, rad). Everything the planner, observation, reward and
simulator need is here so no magic number lives in a function body.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.robot import FOOTPRINT_CENTERS_X, FOOTPRINT_RADIUS


@dataclass(frozen=True)
class RobotLimits:
    """Kinematic limits of the Kachaka base (paper Table "Parameter values")."""

    v_max: float = 0.4
    """Max translational velocity, m/s (the planner keeps v >= 0; only a recovery backs up)."""
    w_max: float = 2.0
    """Max angular velocity, rad/s."""
    a_max: float = 2.0
    """Max translational acceleration, m/s^2."""
    alpha_max: float = 3.0
    """Max angular acceleration, rad/s^2."""

    def __post_init__(self) -> None:
        for name in ("v_max", "w_max", "a_max", "alpha_max"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"RobotLimits.{name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class Footprint:
    """Collision model of the planner: circles of radius r along the body's x axis.

    The paper plans with one r = 0.15 m circle about base_link, which does not cover
    Kachaka's 0.387 x 0.240 m body (its front corners are ~0.27 m from base_link). We keep
    the paper's r and margin m, but place three r-circles along the body centre line so their
    union covers the whole box; a trajectory is admissible when every circle centre stays
    farther than r + m from every scan point.
    """

    radius: float = FOOTPRINT_RADIUS
    """Circle radius r, m (the paper's robot radius)."""
    centers_x: tuple[float, ...] = FOOTPRINT_CENTERS_X
    """Circle centres on the body x axis, m, base_link frame (Kachaka's: d3dwa_bullet.robot)."""

    def __post_init__(self) -> None:
        if self.radius <= 0 or not self.centers_x:
            raise ConfigError(f"Footprint needs radius > 0 and >= 1 centre, got {self!r}")


@dataclass(frozen=True)
class PlannerParams:
    """DWA parameters (docs/design/planner.md#planner)."""

    n_v: int = 20
    """Velocity samples along v."""
    n_w: int = 40
    """Velocity samples along w."""
    dt: float = 0.1
    """Rollout resolution, s."""
    control_period: float = 0.1
    """Control period over which the dynamic window is formed, s."""
    safety_margin: float = 0.05
    """Safety margin m, m: admissible iff clearance > r + m."""
    clearance_cap: float = 1.0
    """Clearance criterion is capped here, m (beyond it a trajectory counts as fully clear)."""
    grid_resolution: float = 0.02
    """Cell size of the clearance lattice (costmap), m."""
    footprint: Footprint = field(default_factory=Footprint)
    limits: RobotLimits = field(default_factory=RobotLimits)

    def __post_init__(self) -> None:
        if self.n_v < 1 or self.n_w < 1:
            raise ConfigError(f"PlannerParams.n_v/n_w must be >= 1, got {self.n_v} x {self.n_w}")
        for name in ("dt", "control_period", "clearance_cap", "grid_resolution"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"PlannerParams.{name} must be > 0, got {getattr(self, name)!r}")
        if self.safety_margin < 0:
            raise ConfigError(
                f"PlannerParams.safety_margin must be >= 0, got {self.safety_margin!r}"
            )

    @property
    def admissible_clearance(self) -> float:
        """r + m: the smallest clearance (circle centre to scan point) that is admissible, m."""
        return self.footprint.radius + self.safety_margin


@dataclass(frozen=True)
class ObservationParams:
    """Observation layout (docs/design/observation.md#observation)."""

    sectors: int = 8
    """Number of angular sectors K."""
    fov: float = float(np.deg2rad(240.0))
    """Field of view covered by the sectors, rad, centred forward."""
    d_max: float = 3.5
    """Max usable range, m."""
    goal_clip: float = 6.0
    """Goal distance clip, m."""

    def __post_init__(self) -> None:
        if (
            self.sectors < 1
            or self.d_max <= 0
            or self.goal_clip <= 0
            or not 0 < self.fov <= 2 * np.pi
        ):
            raise ConfigError(f"ObservationParams out of range: {self!r}")

    @property
    def dim(self) -> int:
        return 4 + self.sectors


PROGRESS_RADIUS = 0.5
"""Progress means leaving a circle of this radius, m (Nav2's SimpleProgressChecker default):
the one number the recovery layer, the progress-aware observation and the stall penalty share."""
PROGRESS_WINDOW = 10.0
"""Nav2's movement time allowance, s: the recovery layer's window, and what the
progress-aware observation divides the time without progress by."""
OBSERVATION_KINDS = ("paper", "progress", "history")
"""What a policy reads: the paper's 12-d state, that state and five progress entries
(docs/design/observation.md#progress-observation), or that state over the last 10 control steps and the
previous action (docs/design/observation.md#history-observation); ``planning.observation_kinds``."""


@dataclass(frozen=True)
class ProgressObservationParams:
    """The five entries the ``progress`` observation appends (docs/design/observation.md#progress-observation)."""

    radius: float = PROGRESS_RADIUS
    """Progress checker radius on the estimated pose, m."""
    window: float = PROGRESS_WINDOW
    """Time without progress is divided by this and clipped to 1, s."""
    weight_max: float = 3.0
    """The previous action's weights are divided by this (the largest of W)."""
    tau_max: float = 5.0
    """The previous action's horizon is divided by this, s (the largest of T)."""

    def __post_init__(self) -> None:
        for name in ("radius", "window", "weight_max", "tau_max"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ConfigError(
                    f"progress observation {name} must be a number > 0, got {value!r}"
                )


@dataclass(frozen=True)
class TerminationParams:
    """When an episode ends (paper Table "Parameter values")."""

    goal_tolerance: float = 0.10
    """Distance from base_link to goal counted as reached, m."""
    collision_distance: float = 0.10
    """Minimum valid lidar range below which the robot counts as collided, m."""
    time_limit: float = 60.0
    """Episode time limit, s."""

    def __post_init__(self) -> None:
        if self.goal_tolerance <= 0 or self.collision_distance < 0 or self.time_limit <= 0:
            raise ConfigError(f"TerminationParams out of range: {self!r}")


@dataclass(frozen=True)
class RewardParams:
    """Reward magnitudes (baseline = DQDWA's, unscaled). D3QN uses scale = 0.01."""

    goal: float = 50.0
    collision: float = -2.0
    timeout: float = -2.0
    step: float = -0.02
    goal_shaping: float = 0.1
    obstacle_shaping: float = 0.05
    scale: float = 1.0
    """Multiplies every term (the D3QN uses 1/100)."""
    stall_penalty: float = 0.0
    """Added to a step that ends with the robot (ground truth) still within PROGRESS_RADIUS of
    where it last made progress more than ``stall_after`` seconds ago (0: the paper's reward)."""
    stall_after: float = 5.0
    """Seconds without progress after which a step pays ``stall_penalty``."""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.stall_penalty) and self.stall_penalty <= 0):
            raise ConfigError(f"stall_penalty must be a number <= 0, got {self.stall_penalty!r}")
        if not (np.isfinite(self.stall_after) and self.stall_after > 0):
            raise ConfigError(
                f"stall_after must be a number of seconds > 0, got {self.stall_after!r}"
            )


@dataclass(frozen=True)
class SimParams:
    """Simulator rates. physics_hz must be a multiple of control_hz."""

    physics_hz: int = 240
    control_hz: int = 10

    def __post_init__(self) -> None:
        if self.physics_hz <= 0 or self.control_hz <= 0:
            raise ConfigError(
                f"SimParams: rates must be positive, got physics_hz={self.physics_hz}, control_hz={self.control_hz}"
            )
        if self.physics_hz % self.control_hz != 0:
            raise ConfigError(
                f"SimParams: physics_hz={self.physics_hz} is not divisible by control_hz={self.control_hz}"
            )

    @property
    def substeps(self) -> int:
        return self.physics_hz // self.control_hz

    @property
    def control_period(self) -> float:
        return 1.0 / self.control_hz


RECOVERY_KINDS = ("none", "nav2")
"""``--recovery`` values: no recovery layer (the paper's stack), or Nav2's progress checker
and recovery sequence adapted to Kachaka (docs/design/recovery.md#recovery)."""
RECOVERY_BEHAVIOURS = ("spin", "back_up")
"""Recovery behaviours a sequence may hold; a per-step log codes them 1, 2 (0 = none)."""


@dataclass(frozen=True)
class RecoveryParams:
    """The recovery layer around any controller (docs/design/recovery.md#recovery); off when an
    episode's ``EpisodeConfig.recovery`` is None.

    Progress is checked on the *estimated* pose with the semantics of Nav2's
    SimpleProgressChecker: the robot must leave a circle of ``radius`` about where it was
    last known to progress within ``window`` seconds. When it does not, the next behaviour of
    ``sequence`` runs (round robin), each motion checked against the planner's footprint
    before and during it; after ``max_recoveries`` the layer gives up and the episode runs on.
    """

    kind: str = "nav2"
    """Name of the recipe (a RECOVERY_KINDS value other than none)."""
    radius: float = PROGRESS_RADIUS
    """Progress checker: required movement radius, m (Nav2 default)."""
    window: float = PROGRESS_WINDOW
    """Progress checker: movement time allowance, s (Nav2 default)."""
    sequence: tuple[str, ...] = RECOVERY_BEHAVIOURS
    """Behaviours tried in turn, one per failed progress check (Nav2's wait dropped)."""
    max_recoveries: int = 6
    """Recoveries per episode before the layer gives up (Nav2's number_of_retries)."""
    spin_angle: float = 1.57
    """Spin: angle turned in place, rad (Nav2's spin_dist)."""
    spin_rate: float = 1.0
    """Spin: turn rate, rad/s (Nav2's max_rotational_vel; Kachaka allows 1.57)."""
    backup_distance: float = 0.30
    """Back-up: distance driven straight back, m (Nav2's backup_dist)."""
    backup_speed: float = 0.15
    """Back-up: speed, m/s (Nav2's backup_speed)."""
    lookahead: float = 1.0
    """Each step a behaviour checks the next this-many seconds of its motion (at most what
    remains of it) and stops where that is not admissible, s (Nav2's simulate_ahead_time is
    2 s, which makes a 1 rad/s spin all or nothing; 1 s lets it turn as far as it can)."""
    behaviour_timeout: float = 10.0
    """A behaviour that has not finished after this long is ended, s (Nav2's time_allowance)."""
    memory: float = 30.0
    """How long scan points are carried along by the estimated pose to check motions
    toward what the 240 deg lidar cannot see now, s."""

    def __post_init__(self) -> None:
        if self.kind not in RECOVERY_KINDS[1:]:
            raise ConfigError(
                f"unknown recovery {self.kind!r}: choose one of {', '.join(RECOVERY_KINDS)}"
            )
        for name in ("radius", "window", "spin_angle", "spin_rate", "backup_distance",
                     "backup_speed", "lookahead", "behaviour_timeout", "memory"):  # fmt: skip
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ConfigError(f"recovery {name} must be a number > 0, got {value!r}")
        unknown = [b for b in self.sequence if b not in RECOVERY_BEHAVIOURS]
        if not self.sequence or unknown:
            raise ConfigError(
                f"recovery sequence {self.sequence!r}: name behaviours among "
                f"{', '.join(RECOVERY_BEHAVIOURS)}"
            )
        if self.max_recoveries < 0:
            raise ConfigError(f"recovery max_recoveries must be >= 0, got {self.max_recoveries}")


def recovery_params(
    kind: str, radius: float | None = None, window: float | None = None
) -> RecoveryParams | None:
    """The RecoveryParams of a ``--recovery`` name (None for "none"), with the progress
    checker's radius (m) and window (s) when given. ConfigError naming a bad value."""
    if kind not in RECOVERY_KINDS:
        raise ConfigError(f"unknown recovery {kind!r}: choose one of {', '.join(RECOVERY_KINDS)}")
    if kind == "none":
        return None
    base = RecoveryParams(kind=kind)
    return RecoveryParams(
        kind=kind,
        radius=base.radius if radius is None else radius,
        window=base.window if window is None else window,
    )
