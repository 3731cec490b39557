"""The global plan's parameters and names (docs/design/global-plan.md): no heavy imports, so a
command checks ``--global-plan`` before it loads the planner (:mod:`~d3dwa_bullet.planning.global_plan`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from d3dwa_bullet.errors import ConfigError

GLOBAL_PLANS = ("none", "scan", "map")
"""``--global-plan`` values: none (the paper's stack, default), scan, map."""
CARROTS = ("along", "sight")
"""The carrot rules (``--carrot``; :mod:`~d3dwa_bullet.planning.carrot`): along (a fixed distance
along the path) and sight (kept in line of sight on the costmap)."""
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
    carrot: str = "along"
    """The carrot rule (CARROTS; :mod:`~d3dwa_bullet.planning.carrot`): ``along`` (lookahead
    along the path) or ``sight`` (kept in line of sight on the costmap); docs/pilots/carrot/."""

    def __post_init__(self) -> None:
        if self.kind not in GLOBAL_PLANS[1:]:
            raise ConfigError(f"global plan {self.kind!r}: choose one of {', '.join(GLOBAL_PLANS)}")
        if self.goal_distance not in GOAL_DISTANCES:
            raise ConfigError(
                f"global plan goal distance {self.goal_distance!r}: choose one of {', '.join(GOAL_DISTANCES)}"
            )
        if self.carrot not in CARROTS:
            raise ConfigError(f"--carrot {self.carrot!r}: choose one of {', '.join(CARROTS)}")
        for name in ("lookahead", "replan_period", "margin"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"GlobalPlanParams.{name} must be a number > 0, got {value!r}")


def global_plan_params(kind: str, carrot: str | None = None) -> GlobalPlanParams | None:
    """The GlobalPlanParams of a ``--global-plan`` value (None for none) with a ``--carrot`` rule
    (None: the default); ConfigError naming the option and the known values otherwise."""
    if kind not in GLOBAL_PLANS:
        raise ConfigError(f"--global-plan {kind!r}: choose one of {', '.join(GLOBAL_PLANS)}")
    if carrot is not None and carrot not in CARROTS:
        raise ConfigError(f"--carrot {carrot!r}: choose one of {', '.join(CARROTS)}")
    if kind == "none":
        if carrot is not None:
            raise ConfigError(
                f"--carrot {carrot} needs --global-plan scan or map (there is no path)"
            )
        return None
    return (
        GlobalPlanParams(kind=kind)
        if carrot is None
        else GlobalPlanParams(kind=kind, carrot=carrot)
    )


def plan_name(params: GlobalPlanParams | None) -> str:
    """The name results carry for a global plan (their ``global_plan`` column and setting):
    "none", the kind ("scan", "map") with the ``along`` carrot, which every run before the
    ``sight`` rule used, or kind+rule otherwise ("scan+sight"), so the two never share a
    directory."""
    if params is None:
        return "none"
    return params.kind if params.carrot == "along" else f"{params.kind}+{params.carrot}"
