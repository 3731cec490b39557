"""Sequential plans: a plan file, its layouts' order, alpha-spending boundaries and the
reading of a cell at each look (docs/design/sequential-plans.md)."""

from d3dwa_bullet.evaluation.plans.boundaries import (
    boundaries,
    crossing_probability,
    drift_for_power,
    spending,
)
from d3dwa_bullet.evaluation.plans.looks import (
    DECISIONS,
    ESTIMATORS,
    Estimate,
    decisions,
    differences_estimate,
    first_reading,
    prefix_estimates,
)
from d3dwa_bullet.evaluation.plans.order import layout_order
from d3dwa_bullet.evaluation.plans.plan_file import Cell, Family, Plan, check_plan, load_plan

__all__ = ["DECISIONS", "ESTIMATORS", "Cell", "Estimate", "Family", "Plan", "boundaries", "check_plan",
           "crossing_probability", "decisions", "differences_estimate", "drift_for_power", "first_reading",
           "layout_order", "load_plan", "prefix_estimates", "spending"]  # fmt: skip
