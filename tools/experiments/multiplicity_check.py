"""A plan's multiplicity control checked by simulation: the familywise false-read rate and the true reads.

Cells are read together under each rule (``simulate.simulate_cells``: per-layout differences
N(true, sd), five equally spaced looks, the plan's boundaries for the t at each cell's level,
``recycling.py``), in two cases fixed here before any run:

- ``mixed``: eight cells of 200 layouts, margin 0.2 sd: two ties (0), one on each margin (+-0.2),
  two large effects (+-0.6) and two inside the margin (+-0.1 with sd 0.25: they read a difference
  and equivalence at once, and so pass their level under Holm);
- ``ties``: four ties of 100 layouts, margin 0.3 sd (each reads equivalent about half the time):
  the case where passing a level on any first read fails.

A false read is a difference read where there is none or in the wrong direction, or equivalence
read on or beyond the margin; a true read is any other read. Printed per case and rule: the
share of replicates with any false read (95 % Wilson interval) and the mean true reads a
replicate. ``--naive`` adds Holm passing a level on any first read (a difference or equivalence;
not the plan's rule), to show why the plan's rule does not. Seeded: the same figures each run.

    python -m tools.experiments.multiplicity_check --replicates 20000 --naive
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from d3dwa_bullet.evaluation.plans.looks import (
    OPEN,
    decisions,
    prefix_estimates,
)
from d3dwa_bullet.evaluation.plans.recycling import LevelBounds, Levels
from d3dwa_bullet.evaluation.plans.simulate import false_and_true, simulate_cells
from d3dwa_bullet.evaluation.stats import wilson_interval
from tools.entry import ToolParser, tool_main

ALPHA = 0.05
LOOKS = 5


class Case(NamedTuple):
    """Simulated cells: true mean differences and sds (per layout), layouts, margin (in sd)."""

    true: list[float]
    sd: list[float]
    layouts: int
    margin: float


CASES = {
    "mixed": Case(
        [0.0, 0.0, 0.2, -0.2, 0.6, -0.6, 0.1, -0.1], [1, 1, 1, 1, 1, 1, 0.25, 0.25], 200, 0.2
    ),
    "ties": Case([0.0, 0.0, 0.0, 0.0], [1, 1, 1, 1], 100, 0.3),
}
"""The cases, fixed before any run (the module's docstring)."""


def naive_holm(
    true: Sequence[float],
    sd: Sequence[float],
    n: int,
    margin: float,
    replicates: int,
    seed: int,
    paths: int,
) -> np.ndarray:
    """(replicates, C) readings under Holm passing a cell's level on its first read of any kind,
    re-read within a look until no cell reads (not the plan's rule: see the module's docstring);
    the same draws as ``simulate_cells`` with the same seed."""
    mean, spread = np.asarray(true, dtype=float), np.asarray(sd, dtype=float)
    d = np.random.default_rng(seed).normal(
        mean[None, :, None], spread[None, :, None], (replicates, mean.size, n)
    )
    looks = np.round(np.arange(1, LOOKS + 1) / LOOKS * n).astype(int)
    diff, se, df = prefix_estimates(d, looks)
    bounds, levels = LevelBounds(looks, n, paths), Levels("holm", ALPHA, mean.size)
    code = np.full((replicates, mean.size), OPEN)
    for k in range(LOOKS):
        while True:
            bd, bt = bounds.look(levels.level((code != OPEN).sum(axis=1)), k)
            got = decisions(diff[..., k], se[..., k], df[..., k], margin, bd[:, None], bt[:, None])
            new = (code == OPEN) & (got != OPEN)
            if not new.any():
                break
            code = np.where(new, got, code)
    return code


def check(name: str, replicates: int, seed: int, paths: int, naive: bool) -> list[dict]:
    """Each rule's figures in one case (see the module's docstring)."""
    true, sd, n, margin = CASES[name]
    out = []
    for rule in ("none", "bonferroni", "holm", *(("holm, any read passes",) if naive else ())):
        if rule.startswith("holm,"):
            code = naive_holm(true, sd, n, margin, replicates, seed, paths)
        else:
            code = simulate_cells(
                true, sd, n, margin, LOOKS, replicates, seed, Levels(rule, ALPHA, len(true)), paths
            )
        false, right = false_and_true(code, np.asarray(true), margin)
        low, high = wilson_interval(int(false.sum()), replicates)
        out.append({"case": name, "rule": rule, "cells": len(true), "replicates": replicates,
                    "familywise_false_read": float(false.mean()), "low": low, "high": high,
                    "true_reads": float(right.mean())})  # fmt: skip
    return out


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="multiplicity_check", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--replicates", type=int, default=20_000, help="replicates a case and rule (default 20000)"
    )
    parser.add_argument(
        "--paths",
        type=int,
        default=2_000_000,
        help="null paths of each level's bounds (default 2000000, the plan's)",
    )
    parser.add_argument("--seed", type=int, default=0, help="the draws' seed (default 0)")
    parser.add_argument(
        "--naive", action="store_true", help="add Holm passing a level on any first read"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if not 100 <= args.replicates <= 200_000:
        parser.error(f"--replicates must be in 100..200000, got {args.replicates}")
    if not 10_000 <= args.paths <= 20_000_000:
        parser.error(f"--paths must be in 10000..20000000, got {args.paths}")
    if args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    out = [
        r
        for i, name in enumerate(CASES)
        for r in check(name, args.replicates, args.seed + i, args.paths, args.naive)
    ]
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    print("| case | cells | rule | any false read | true reads |")
    print("|---|---:|---|---:|---:|")
    for r in out:
        rate = f"{100 * r['familywise_false_read']:.2f} % [{100 * r['low']:.2f}, {100 * r['high']:.2f}]"
        print(f"| {r['case']} | {r['cells']} | {r['rule']} | {rate} | {r['true_reads']:.3f} |")
    print(f"{args.replicates:,} replicates a case and rule; alpha {ALPHA}, {LOOKS} looks; bounds from "
          f"{args.paths:,} null paths a level.")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
