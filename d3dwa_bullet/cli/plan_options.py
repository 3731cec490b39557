"""``--global-plan``: the option that puts a global plan under every method (beyond the paper,
off by default; docs/design/global-plan.md), on the commands that run simulated episodes."""

from __future__ import annotations

import argparse

from d3dwa_bullet.planning.global_plan_params import (
    CARROTS,
    GLOBAL_PLANS,
    GlobalPlanParams,
    global_plan_params,
)


def add_global_plan_option(p: argparse.ArgumentParser) -> None:
    """--global-plan none|scan|map and --carrot along|sight."""
    p.add_argument(
        "--global-plan",
        default="none",
        help=f"global plan every method follows: {', '.join(GLOBAL_PLANS)} (none: the paper's "
        "stack, default; scan: a costmap from the robot's own scans; map: the world's known map, "
        "a privileged reference; beyond the paper: docs/design/global-plan.md)",
    )
    p.add_argument(
        "--carrot",
        default=None,
        help=f"the carrot a global plan's follower drives toward: {', '.join(CARROTS)} (along: "
        f"lookahead along the path; sight: kept in line of sight on the costmap; default "
        f"{GlobalPlanParams().carrot}; docs/design/global-plan.md)",
    )


def global_plan_arg(args: argparse.Namespace) -> GlobalPlanParams | None:
    """The GlobalPlanParams of --global-plan (None for none, or a command without the option);
    ConfigError (one line, exit 2) naming the option and the known values otherwise."""
    return global_plan_params(getattr(args, "global_plan", "none"), getattr(args, "carrot", None))
