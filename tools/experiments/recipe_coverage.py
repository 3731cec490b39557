"""The recipe-level reading checked by simulation: coverage and type I at known variances.

Each case draws REPLICATES pairs of (seeds x layouts) tables from the crossed model with known
seed, layout and residual sds (B's layout effect correlated with A's; B fixed where the case
says so), and prints, for the recipe's 95 % interval and for today's ("these policies"), how
often it covers the true A - B over seeds and layouts, and how often a difference is read when
there is none (docs/design/readings-recipe.md; tests/evaluation/test_recipe.py asserts them).

    python -m tools.experiments.recipe_coverage            # a Markdown table
    python -m tools.experiments.recipe_coverage --json
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np
from scipy import stats

from d3dwa_bullet.evaluation.recipe import policies_arrays, recipe_arrays
from tools.entry import ToolParser, tool_main

REPLICATES = 4000
CASES = [
    # seeds, layouts, sd of A's seeds, of B's, of layouts, of the residual, B fixed
    (5, 50, 0.05, 0.05, 0.1, 0.2, False),  # seed spread large against residual / L
    (5, 50, 0.0, 0.0, 0.1, 0.2, False),  # no seed variance: the recipe is these policies
    (5, 50, 0.1, 0.05, 0.1, 0.3, True),  # a learned side against a fixed one
    (2, 30, 0.05, 0.05, 0.1, 0.3, False),  # two seeds: one df per seed term
    (5, 50, 0.02, 0.02, 0.1, 0.3, False),  # seed spread small against residual / L
    (3, 200, 0.01, 0.0, 0.05, 0.3, False),  # one side without seed variance, many layouts
    (5, 300, 0.05, 0.05, 0.1, 0.2, False),  # the point: many layouts, seeds vary
]
"""The simulated designs, fixed before any result was seen."""


def simulate(
    seeds, layouts, sd_seed_a, sd_seed_b, sd_layout, sd_resid, fixed_b=False, delta=0.0, seed=0
):
    """REPLICATES draws of both sides' tables: (a (R, S, L), b (R, S_B, L)); true A - B delta."""
    rng = np.random.default_rng(seed)
    r, s_b = REPLICATES, 1 if fixed_b else seeds
    layout_a = rng.normal(0, sd_layout, (r, 1, layouts))
    layout_b = 0.5 * layout_a + rng.normal(0, sd_layout, (r, 1, layouts))
    a = (
        delta
        + rng.normal(0, sd_seed_a, (r, seeds, 1))
        + layout_a
        + rng.normal(0, sd_resid, (r, seeds, layouts))
    )
    seed_b = 0.0 if fixed_b else rng.normal(0, sd_seed_b, (r, s_b, 1))
    b = seed_b + layout_b + rng.normal(0, sd_resid, (r, s_b, layouts))
    return a, b


def coverage(fn, a: np.ndarray, b: np.ndarray, delta: float = 0.0) -> float:
    """How often fn's 95 % t interval ((mean, se, df) of fn(a, b)) holds delta."""
    mean, se, df = fn(a, b)
    return float(np.mean(np.abs(mean - delta) <= stats.t.ppf(0.975, df) * se))


def measure() -> list[dict[str, float | int | bool]]:
    """Per case: the recipe's and today's coverage of a true +0.04, and their rates of reading
    a difference when there is none (1 - coverage of 0)."""
    out = []
    for case in CASES:
        a, b = simulate(*case, delta=0.04, seed=1)
        a0, b0 = simulate(*case, seed=2)
        keys = ("seeds", "layouts", "sd_seed_a", "sd_seed_b", "sd_layout", "sd_resid", "b_fixed")
        out.append(dict(zip(keys, case, strict=True)) | {
            "recipe_coverage": coverage(recipe_arrays, a, b, 0.04),
            "policies_coverage": coverage(policies_arrays, a, b, 0.04),
            "recipe_type1": 1 - coverage(recipe_arrays, a0, b0),
            "policies_type1": 1 - coverage(policies_arrays, a0, b0),
        })  # fmt: skip
    return out


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="recipe_coverage", description=__doc__.split("\n")[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = measure()
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"| S | L | sd seeds | sd layout | sd res. | B | recipe cover | policies cover "
          f"| recipe type I | policies type I |\n|{'---:|' * 10}")  # fmt: skip
    for r in rows:
        print(f"| {r['seeds']} | {r['layouts']} | {r['sd_seed_a']}, {r['sd_seed_b']} | {r['sd_layout']} | "
              f"{r['sd_resid']} | {'fixed' if r['b_fixed'] else 'learned'} | {100 * r['recipe_coverage']:.1f} % | "
              f"{100 * r['policies_coverage']:.1f} % | {100 * r['recipe_type1']:.1f} % | "
              f"{100 * r['policies_type1']:.1f} % |")  # fmt: skip
    print(f"\n{REPLICATES:,} replicates a case; Monte Carlo se of a 95 % coverage: 0.34 points.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
