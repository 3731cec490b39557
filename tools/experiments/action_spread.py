"""What a policy chooses: how widely its (weights, horizon) choices spread, per run.

Reads every episode's per-step log of a sweep (or eval) directory and, per (noise, method,
training seed), counts the steps spent on each (wp, wc, ws, tau) tuple. It prints the number of
tuples used, the *perplexity* of that time-share histogram (exp of its entropy: 1 for a policy
that holds one tuple, 100 for one spread evenly over the 100 actions) and the share of steps on
one reference tuple (by default DWA III's, ``--tuple dwa3``; 1 % is the uniform chooser's share).
A diagnostic for issue 40: does a policy trained under noise settle on the tuple the fixed
planner wins with?

    python -m tools.experiments.action_spread runs/r3-nav2 --methods d3dwa-dr
"""

from __future__ import annotations

import json
import sys
from collections import Counter, defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import D3DWAError, ResultsError
from d3dwa_bullet.evaluation.jobs import log_name
from d3dwa_bullet.evaluation.results import job_rows, load_log, row_key
from d3dwa_bullet.method_specs import FIXED
from tools.entry import ToolParser, tool_main

Tuple4 = tuple[float, float, float, float]


def perplexity(counts: Counter[Tuple4]) -> float:
    """exp(entropy) of the histogram counts: the effective number of tuples."""
    p = np.array(list(counts.values()), dtype=float)
    p = p[p > 0] / p.sum()
    return float(np.exp(-(p * np.log(p)).sum()))


def reference_tuple(name: str) -> Tuple4:
    """A fixed method's (wp, wc, ws, tau); ResultsError naming an unknown one."""
    if name not in FIXED:
        raise ResultsError(f"--tuple: {name!r} is not a fixed method ({', '.join(sorted(FIXED))})")
    a = FIXED[name]
    return (a.wp, a.wc, a.ws, a.tau)


def spread(out: Path, methods: Sequence[str], reference: Tuple4) -> list[dict[str, Any]]:
    """One record per (noise, method, policy seed) of the chosen methods."""
    if not (out / "results.csv").is_file():
        raise ResultsError(f"{out}: no results.csv")
    counts: dict[tuple[str, str, str], Counter[Tuple4]] = defaultdict(Counter)
    for r in job_rows(out):
        if r["method"] not in methods:
            continue
        path = out / "logs" / log_name(row_key(r))
        if not path.is_file():
            raise ResultsError(f"{path}: no per-step log for this episode")
        log = load_log(path)
        steps = zip(log["wp"], log["wc"], log["ws"], log["tau"], strict=True)
        counts[(r["noise"], r["method"], r["policy_seed"])].update(
            (float(wp), float(wc), float(ws), float(tau)) for wp, wc, ws, tau in steps
        )
    if not counts:
        raise ResultsError(f"{out}: no episodes of {', '.join(methods)}")
    return [
        {
            "noise": noise,
            "method": method,
            "policy_seed": seed,
            "steps": sum(c.values()),
            "tuples": len(c),
            "perplexity": perplexity(c),
            "reference_share": c[reference] / sum(c.values()),
        }  # fmt: skip
        for (noise, method, seed), c in sorted(counts.items())
    ]


def markdown(records: Sequence[dict[str, Any]], reference: str) -> str:
    head = ["noise", "method", "seed", "steps", "tuples used", "perplexity", f"{reference} share"]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for r in records:
        lines.append(
            f"| {r['noise']} | {r['method']} | {r['policy_seed'] or '-'} | {r['steps']} | {r['tuples']} "
            f"| {r['perplexity']:.0f} | {100 * r['reference_share']:.1f} % |"
        )
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="action_spread", description=__doc__.split("\n")[0])
    parser.add_argument("dir", type=Path, help="a results directory of `d3dwa sweep` or `eval`")
    parser.add_argument("--methods", required=True, help="comma-separated methods to read")
    parser.add_argument("--tuple", default="dwa3", help="the reference fixed method's tuple")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        reference = reference_tuple(args.tuple)
        methods = [m for m in args.methods.split(",") if m]
        records = spread(args.dir, methods, reference)
    except D3DWAError as exc:
        print(f"action_spread: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(records, indent=1) if args.json else markdown(records, args.tuple), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
