"""The sequential rule checked by simulation: type I of each reading, power at the design effect.

For k equally spaced looks (each of ``--looks``), per-layout differences N(true, 1):
- no difference (true 0, ``--layouts`` layouts, margin ``--margin``): how often a difference
  reads (either way); at most alpha;
- a true difference on the margin (+margin and -margin): how often equivalence reads; at most
  alpha;
- the design effect (``--effect``) at the maximum ``maximum_layouts`` sizes for 80 % power:
  how often "A better" reads, and the share of those read before the maximum.
Each rate with its 95 % Wilson interval over the replicates (seeded: the same figures each run).
The difference's level is then measured finer, on ``--paths`` null paths drawn from their
sufficient statistics (``student.null_tails``, seeds apart from the bounds'): twice the chance
that A > B crosses at some look (the two directions have one law; TOST's stops ignored, so an
upper bound), for the normal boundaries read through the t's tail (the rule before issue 77's
fix) and for the t's own (``student.t_boundaries``, the rule now).

    python -m tools.experiments.sequential_check --replicates 100000 --paths 4000000
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from d3dwa_bullet.evaluation.plans.boundaries import boundaries, maximum_layouts
from d3dwa_bullet.evaluation.plans.looks import A_BETTER, B_BETTER, EQUIVALENT
from d3dwa_bullet.evaluation.plans.simulate import simulate
from d3dwa_bullet.evaluation.plans.student import null_tails, t_boundaries
from d3dwa_bullet.evaluation.stats import wilson_interval
from tools.entry import ToolParser, tool_main


def _rate(hits: np.ndarray) -> dict[str, float]:
    k, n = int(hits.sum()), int(hits.size)
    low, high = wilson_interval(k, n)
    return {"rate": k / n, "low": low, "high": high}


def level(looks: int, layouts: int, paths: int, seed: int) -> dict:
    """The difference's level (twice one side's crossing chance, 95 % Wilson interval doubled)
    over ``paths`` null paths at ``looks`` equally spaced looks of ``layouts``, for the normal
    bounds and for the t's."""
    n = np.round(np.arange(1, looks + 1) / looks * layouts).astype(int)
    bounds = {"normal": boundaries(n / layouts, 0.025), "t": t_boundaries(n, layouts, 0.025)}
    floor = min(float(b.min()) for b in bounds.values()) - 0.1
    path, look, value = null_tails(tuple(int(x) for x in n), paths, 1_000 + seed, floor)[0]
    out = {}
    for name, b in bounds.items():
        k = int(np.unique(path[value >= b[look]]).size)
        low, high = wilson_interval(k, paths)
        out[name] = {"rate": 2 * k / paths, "low": 2 * low, "high": 2 * high}
    return out


def check(
    looks: int, layouts: int, margin: float, effect: float, replicates: int, seed: int
) -> dict:
    """The figures for one number of looks (see the module's docstring)."""
    alpha = 0.05
    null, _ = simulate(0.0, layouts, margin, looks, replicates, seed, alpha)
    upper, _ = simulate(margin, layouts, margin, looks, replicates, seed + 1, alpha)
    lower, _ = simulate(-margin, layouts, margin, looks, replicates, seed + 2, alpha)
    n = maximum_layouts(effect, 1.0, np.arange(1, looks + 1) / looks, alpha / 2, 0.8)
    power, at = simulate(effect, n, margin, looks, replicates, seed + 3, alpha)
    return {
        "looks": looks, "replicates": replicates,
        "difference_when_none": _rate(np.isin(null, [A_BETTER, B_BETTER])),
        "equivalent_on_upper_margin": _rate(upper == EQUIVALENT),
        "equivalent_on_lower_margin": _rate(lower == EQUIVALENT),
        "design_layouts": n, "power": _rate(power == A_BETTER),
        "read_before_maximum": float(np.mean(at[power == A_BETTER] < looks - 1)),
    }  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="sequential_check", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--looks", default="5,10", help="numbers of equally spaced looks (default 5,10)"
    )
    parser.add_argument(
        "--layouts", type=int, default=200, help="layouts of the type I runs (default 200)"
    )
    parser.add_argument(
        "--margin", type=float, default=0.2, help="margin in per-layout sd (default 0.2)"
    )
    parser.add_argument(
        "--effect", type=float, default=0.25, help="design effect in sd (default 0.25)"
    )
    parser.add_argument(
        "--replicates", type=int, default=20_000, help="cells per figure (default 20000)"
    )
    parser.add_argument(
        "--paths",
        type=int,
        default=2_000_000,
        help="null paths of the level's finer figure (default 2000000)",
    )
    parser.add_argument("--seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        looks = [int(x) for x in args.looks.split(",")]
    except ValueError:
        parser.error(f"--looks must be a comma list of whole numbers, got {args.looks!r}")
    if not all(1 <= k <= 50 for k in looks):
        parser.error(f"--looks must be between 1 and 50 each, got {args.looks!r}")
    if args.layouts < 2 * max(looks) or not 100 <= args.replicates <= 1_000_000:
        parser.error("--layouts must be at least twice the looks and --replicates in 100..1000000")
    if not 1_000 <= args.paths <= 20_000_000:
        parser.error(f"--paths must be in 1000..20000000, got {args.paths}")
    if not (0 < args.margin < 5 and 0 < args.effect < 5):
        parser.error(
            f"--margin and --effect must be in (0, 5) sd, got {args.margin:g}, {args.effect:g}"
        )
    out = [check(k, args.layouts, args.margin, args.effect, args.replicates, args.seed + 10 * i)
           for i, k in enumerate(looks)]  # fmt: skip
    for i, (r, k) in enumerate(zip(out, looks, strict=True)):
        r["difference_level"] = level(k, args.layouts, args.paths, args.seed + 10 * i)
    if args.json:
        print(json.dumps(out, indent=1))
        return 0

    def text(r: dict[str, float]) -> str:
        return f"{100 * r['rate']:.2f} % [{100 * r['low']:.2f}, {100 * r['high']:.2f}]"

    print(
        "| looks | difference, none true | equivalent, +margin | equivalent, -margin | layouts | power |"
    )
    print("|---:|---:|---:|---:|---:|---:|")
    for r in out:
        print(f"| {r['looks']} | {text(r['difference_when_none'])} | {text(r['equivalent_on_upper_margin'])} | "
              f"{text(r['equivalent_on_lower_margin'])} | {r['design_layouts']} | {text(r['power'])} |")  # fmt: skip
    print(f"{args.replicates:,} replicates each; margin {args.margin:g} sd, {args.layouts} layouts; design "
          f"effect {args.effect:g} sd (alpha 0.05: a difference at 0.025 each way, TOST at 0.05).")  # fmt: skip
    print()
    print(
        "| looks | difference level, normal bounds through the t's tail | difference level, the t's bounds |"
    )
    print("|---:|---:|---:|")
    for r in out:
        lv = r["difference_level"]
        print(f"| {r['looks']} | {text(lv['normal'])} | {text(lv['t'])} |")
    print(
        f"{args.paths:,} null paths of {args.layouts} layouts each (twice one side's crossing; TOST's stops ignored)."
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
