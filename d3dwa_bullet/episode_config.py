"""What an episode needs besides the world, the controller and the seed: pure parameters, so a
command can build and check it before importing the simulator (``d3dwa_bullet.episode``
re-exports it)."""

from __future__ import annotations

from dataclasses import dataclass, field

from d3dwa_bullet.params import (
    ObservationParams,
    PlannerParams,
    RecoveryParams,
    SimParams,
    TerminationParams,
)
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams, plan_name
from d3dwa_bullet.planning.scan_filter import check_scan_filter
from d3dwa_bullet.sim.backend import DEFAULT_BACKEND, check_backend
from d3dwa_bullet.sim.lidar_params import LidarParams


@dataclass(frozen=True)
class EpisodeConfig:
    """Everything an episode needs besides the world, the controller and the seed."""

    sim: SimParams = field(default_factory=SimParams)
    planner: PlannerParams = field(default_factory=PlannerParams)
    observation: ObservationParams = field(default_factory=ObservationParams)
    termination: TerminationParams = field(default_factory=TerminationParams)
    lidar: LidarParams = field(default_factory=LidarParams)
    recovery: RecoveryParams | None = None
    """The recovery layer around the controller (beyond the paper; None = the paper's stack)."""
    scan_filter: str = "none"
    """The scan filter chain between the lidar and everything that reads it (beyond the paper,
    :data:`~d3dwa_bullet.planning.scan_filter.SCAN_FILTERS`; "none" = the paper's stack)."""
    global_plan: GlobalPlanParams | None = None
    """The global plan the controller follows (beyond the paper; None = the paper's stack)."""

    backend: str = DEFAULT_BACKEND
    """The simulator backend (:data:`~d3dwa_bullet.sim.backend.BACKENDS`): PyBullet, the reference,
    or the kinematic one (docs/design/backends.md)."""

    def __post_init__(self) -> None:
        check_scan_filter(self.scan_filter)
        check_backend(self.backend)

    @property
    def recovery_name(self) -> str:
        """The ``--recovery`` name of this config: "none" or the recipe's kind."""
        return "none" if self.recovery is None else self.recovery.kind

    @property
    def global_plan_name(self) -> str:
        """The ``--global-plan`` name results carry for this config: "none", "scan" or "map",
        with "+sight" under the ``sight`` carrot (``global_plan_params.plan_name``)."""
        return plan_name(self.global_plan)
