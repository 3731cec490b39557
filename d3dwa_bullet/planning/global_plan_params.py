"""The global plan's parameters and names (docs/design/global-plan.md): no heavy imports, so a
command checks ``--global-plan`` before it loads the planner (:mod:`~d3dwa_bullet.planning.global_plan`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from d3dwa_bullet.errors import ConfigError

GLOBAL_PLANS = ("none", "scan", "map")
"""``--global-plan`` values: none (the paper's stack, default), scan, map."""
GOAL_DISTANCES = ("carrot", "path")
"""What a policy's goal distance reads under a global plan: the carrot's distance, or the
path length left to the goal (the carrot's bearing either way)."""


@dataclass(frozen=True)
class GlobalPlanParams:
    """The global plan of an episode (beyond the paper; docs/design/global-plan.md)."""

    kind: str = "scan"
    """``scan`` (a costmap from the robot's own scans) or ``map`` (the world's known map)."""
    lookahead: float = 2.0
    """Carrot distance along the path, m: what the DWA's longest horizon (5 s) covers at v_max
    (0.4 m/s), so its end-point progress criterion never favours stopping short of the carrot."""
    replan_period: float = 1.0
    """Seconds between replans (Nav2's default tree replans at 1 Hz)."""
    margin: float = 3.0
    """A scan costmap covers the box around start and goal grown by this much, m."""
    goal_distance: str = "path"
    """What a policy's goal distance reads (GOAL_DISTANCES; the pilot in the design page)."""

    def __post_init__(self) -> None:
        if self.kind not in GLOBAL_PLANS[1:]:
            raise ConfigError(f"global plan {self.kind!r}: choose one of {', '.join(GLOBAL_PLANS)}")
        if self.goal_distance not in GOAL_DISTANCES:
            raise ConfigError(
                f"global plan goal distance {self.goal_distance!r}: choose one of {', '.join(GOAL_DISTANCES)}"
            )
        for name in ("lookahead", "replan_period", "margin"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"GlobalPlanParams.{name} must be a number > 0, got {value!r}")


def global_plan_params(kind: str) -> GlobalPlanParams | None:
    """The GlobalPlanParams of a ``--global-plan`` value (None for none); ConfigError naming
    the option and the known values otherwise."""
    if kind not in GLOBAL_PLANS:
        raise ConfigError(f"--global-plan {kind!r}: choose one of {', '.join(GLOBAL_PLANS)}")
    return None if kind == "none" else GlobalPlanParams(kind=kind)
