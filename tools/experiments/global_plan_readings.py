"""Issue 80's pooled readings of the global plan: collisions per 1,000 episodes, and the moonshot.

Reads results directories of ``d3dwa eval`` / ``d3dwa sweep`` run with and without ``--global-plan``
(the ``global_plan`` column; a directory without it ran none) and prints two tables:

- **collisions per 1,000 episodes** under each plan, pooled and per noise profile and world family, with
  the Wilson 95 % interval (statsmodels' ``proportion_confint``). Only episodes that ran under every
  plan given are counted (the same world, method, training seed, evaluation seed and profile), so the
  plans are compared on the same episodes; how many were left out is printed.
- **the moonshot** (docs/design/global-plan.md#moonshot): each method's success per (world family,
  profile) under each plan, with Wilson intervals, and whether every cell is at 90 % or more (the
  point estimate) and whether every interval's lower bound is (the rate shown to be there). Here every
  episode is counted, matched or not.
- **failures under a plan**: each failed episode's plan log (``logs/*.npz``): how many ever fell back to
  the goal direction (a ``plan_status`` other than ok: no path, goal blocked, off the costmap), and the
  share of their steps spent so, per plan and profile.

    python -m tools.experiments.global_plan_readings runs/gp-noise/*-*/ --json

``--compare FILE...`` instead prints one table row per ``d3dwa compare --json`` record (its ``all`` group):
success with / without, the difference in points and the robot and BARN score differences with their 95 % t
intervals, and the reading of each, as docs/design/global-plan.md#noise shows them.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from statsmodels.stats.proportion import proportion_confint

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.columns import GLOBAL_PLAN_FIELD
from d3dwa_bullet.evaluation.job import log_name
from d3dwa_bullet.evaluation.results import read_results
from d3dwa_bullet.loading import load_json
from tools.entry import ToolParser, tool_main

TARGET = 0.90
"""The moonshot's success target (issue 80): 90 % or more under every profile and world family."""

ALL = "all"

Key = tuple[str, str, Any, int, str]


def plan_of(row: Mapping[str, Any]) -> str:
    """The row's global plan: its column, or ``none`` in a directory run without one."""
    return str(row.get(GLOBAL_PLAN_FIELD) or "none")


def family_of(world: str) -> str:
    """``BARN`` for BARN's worlds, ``R-style`` for generated R1/R2/R3-style layouts, else the name."""
    if world.startswith("BARN-") and world[5:].isdigit():
        return "BARN"
    if world[:1] == "R" and "-style-s" in world:
        return "R-style"
    return world


def method_label(row: Mapping[str, Any]) -> str:
    """``dwa3``, or ``d3dwa s0`` for a learned method's training seed."""
    seed = row.get("policy_seed")
    return str(row["method"]) if seed in (None, "") else f"{row['method']} s{seed}"


def episode_key(row: Mapping[str, Any]) -> Key:
    return (row["world"], row["method"], row.get("policy_seed"), int(row["seed"]), row["noise"])


def rate(k: int, n: int) -> dict[str, Any]:
    """k of n with the Wilson 95 % interval (nan bounds at n = 0)."""
    lo, hi = proportion_confint(k, n, alpha=0.05, method="wilson") if n else (float("nan"),) * 2
    return {
        "k": k,
        "n": n,
        "rate": k / n if n else float("nan"),
        "wilson95": [float(lo), float(hi)],
    }


def by_plan(
    rows: Iterable[Mapping[str, Any]], source: str = "rows"
) -> dict[str, dict[Key, Mapping[str, Any]]]:
    """Rows by plan and episode key; ValueError naming the key if one episode is given twice."""
    out: dict[str, dict[Key, Mapping[str, Any]]] = defaultdict(dict)
    for row in rows:
        plan, key = plan_of(row), episode_key(row)
        if key in out[plan]:
            raise ValueError(f"{source}: episode {key} under global plan {plan!r} is given twice")
        out[plan][key] = row
    return dict(out)


def collision_rates(plans: Mapping[str, Mapping[Key, Mapping[str, Any]]]) -> dict[str, Any]:
    """Collisions per 1,000 matched episodes under each plan: pooled (``all``), per profile, per
    family, per (family, profile). Rates are fractions; multiply by 1,000 to read them per 1,000."""
    matched = set.intersection(*(set(rows) for rows in plans.values())) if plans else set()
    cells: dict[str, dict[str, Any]] = {}
    for plan, rows in sorted(plans.items()):
        counts: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
        for key in matched:
            row = rows[key]
            hit = int(row["outcome"] == "collision")
            for group in ((ALL, ALL), (ALL, row["noise"]), (family_of(row["world"]), ALL),
                          (family_of(row["world"]), row["noise"])):  # fmt: skip
                counts[group][0] += hit
                counts[group][1] += 1
        cells[plan] = {
            f"{fam} / {noise}": rate(k, n) for (fam, noise), (k, n) in sorted(counts.items())
        }
    left_out = {plan: len(rows) - len(matched) for plan, rows in sorted(plans.items())}
    return {"matched_episodes": len(matched), "left_out": left_out, "cells": cells}


def moonshot(plans: Mapping[str, Mapping[Key, Mapping[str, Any]]]) -> dict[str, Any]:
    """Per plan and method: success per (family, profile), the lowest cell, and the two verdicts."""
    out: dict[str, Any] = {}
    for plan, rows in sorted(plans.items()):
        counts: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(lambda: [0, 0]))
        for row in rows.values():
            cell = counts[method_label(row)][f"{family_of(row['world'])} / {row['noise']}"]
            cell[0] += int(row["outcome"] == "goal")
            cell[1] += 1
        out[plan] = {}
        for method, method_cells in sorted(counts.items()):
            rates = {cell: rate(k, n) for cell, (k, n) in sorted(method_cells.items())}
            out[plan][method] = {
                "cells": rates,
                "lowest": min(r["rate"] for r in rates.values()),
                "every_cell_at_target": all(r["rate"] >= TARGET for r in rates.values()),
                "every_lower_bound_at_target": all(
                    r["wilson95"][0] >= TARGET for r in rates.values()
                ),
            }
    return out


def plan_failures(out: Path, rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One record per failed episode under a plan in results directory ``out``: its key, outcome,
    the share of its observations whose ``plan_status`` was not ok (0 to 1), and its replans. An
    episode whose log is missing is recorded with ``None`` for both (never guessed)."""
    found = []
    for row in rows:
        if plan_of(row) == "none" or row["outcome"] == "goal":
            continue
        record: dict[str, Any] = {"key": list(episode_key(row)), "plan": plan_of(row), "noise": row["noise"],
                                  "method": method_label(row), "outcome": row["outcome"],
                                  "off_plan_share": None, "replans": None}  # fmt: skip
        path = out / "logs" / log_name(episode_key(row))
        if path.exists():
            with np.load(path) as log:
                status = np.asarray(log["plan_status"])
                record["off_plan_share"] = float(np.mean(status != 0)) if status.size else 0.0
                record["replans"] = int(log["plan_replans"])
        found.append(record)
    return found


def failure_summary(failures: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Per plan / profile / method: failed episodes, how many ever left the plan, their mean share off it."""
    groups: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for f in failures:
        groups[f"{f['plan']} / {f['noise']} / {f['method']}"].append(f)
    out = {}
    for name, fs in sorted(groups.items()):
        logged = [f for f in fs if f["off_plan_share"] is not None]
        out[name] = {
            "failed": len(fs),
            "collisions": sum(f["outcome"] == "collision" for f in fs),
            "logged": len(logged),
            "ever_off_plan": sum(f["off_plan_share"] > 0 for f in logged),
            "mean_off_plan_share": float(np.mean([f["off_plan_share"] for f in logged]))
            if logged
            else None,
        }
    return out


def _interval(r: Mapping[str, Any], scale: float, digits: int) -> str:
    lo, hi = (scale * b for b in r["wilson95"])
    return f"{scale * r['rate']:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def text(report: Mapping[str, Any]) -> str:
    col = report["collisions"]
    lines = [
        f"Collisions per 1,000 episodes (Wilson 95 %), on {col['matched_episodes']} episodes run under every plan "
        f"(left out, unmatched: {col['left_out']})",
        "",
        "| plan | family / profile | episodes | collisions | per 1,000 [95 % interval] |",
        "|---|---|---:|---:|---|",
    ]
    for plan, cells in col["cells"].items():
        lines += [
            f"| {plan} | {c} | {r['n']} | {r['k']} | {_interval(r, 1000, 1)} |"
            for c, r in cells.items()
        ]
    lines += [
        "",
        f"Moonshot: success per cell (Wilson 95 %), target {TARGET:.0%} in every cell",
        "",
    ]
    lines += [
        "| plan | method | family / profile | goals | success % [95 % interval] |",
        "|---|---|---|---:|---|",
    ]
    for plan, methods in report["moonshot"].items():
        for method, m in methods.items():
            for c, r in m["cells"].items():
                lines.append(
                    f"| {plan} | {method} | {c} | {r['k']}/{r['n']} | {_interval(r, 100, 1)} |"
                )
    lines += [
        "",
        "| plan | method | lowest cell % | every cell >= target | every lower bound >= target |",
    ]
    lines += ["|---|---|---:|---|---|"]
    for plan, methods in report["moonshot"].items():
        for method, m in methods.items():
            lines.append(
                f"| {plan} | {method} | {100 * m['lowest']:.1f} | {m['every_cell_at_target']} | "
                f"{m['every_lower_bound_at_target']} |"
            )
    lines += [
        "",
        "Failures under a plan: how many ever fell back to the goal direction (plan status not ok)",
        "",
    ]
    lines += [
        "| plan / profile / method | failed | collisions | ever off the plan | mean share of steps off it |"
    ]
    lines += ["|---|---:|---:|---:|---:|"]
    for name, f in report["failures"].items():
        share = "-" if f["mean_off_plan_share"] is None else f"{f['mean_off_plan_share']:.2f}"
        lines.append(
            f"| {name} | {f['failed']} | {f['collisions']} | {f['ever_off_plan']}/{f['logged']} | {share} |"
        )
    return "\n".join(lines)


def readings(dirs: Sequence[Path]) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    failures: list[dict[str, Any]] = []
    for d in dirs:
        found = read_results(d)
        if not found:
            raise ValueError(
                f"{d}: no results.csv rows (is it a results directory of eval or sweep?)"
            )
        rows += found
        failures += plan_failures(d, found)
    plans = by_plan(rows, source=", ".join(str(d) for d in dirs))
    return {
        "dirs": [str(d) for d in dirs],
        "collisions": collision_rates(plans),
        "moonshot": moonshot(plans),
        "failures": failure_summary(failures),
    }


def compare_row(record: Mapping[str, Any], label: str) -> str:
    """One page row from a ``d3dwa compare --json`` record's ``all`` group; ValueError if it has none."""
    groups = {g["group"]: g for g in record.get("groups", [])}
    if "all" not in groups:
        raise ValueError(f"{label}: no 'all' group in the compare record")
    r = groups["all"]["readings"]

    def diff(metric: str, scale: float, digits: int) -> str:
        m = r[metric]
        low, high = (
            f"{scale * m[b]:+.{digits}f}" if m[b] is not None else "-" for b in ("low", "high")
        )
        return f"{scale * m['difference']:+.{digits}f} [{low}, {high}]"

    s = r["success"]
    readings = "; ".join(f"{k} {r[k]['reading']}" for k in ("success", "score", "score_barn"))
    return (
        f"| {label} | {s['layouts']} | {100 * s['mean_a']:.1f} / {100 * s['mean_b']:.1f} | "
        f"{diff('success', 100, 1)} | {diff('score', 1, 3)} | {diff('score_barn', 1, 3)} | {readings} |"
    )


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "dirs", nargs="+", type=Path, help="results directories, with and without --global-plan"
    )
    ap.add_argument("--json", action="store_true")
    ap.add_argument(
        "--compare", action="store_true", help="the paths are `d3dwa compare --json` outputs"
    )
    args = ap.parse_args(argv)
    try:
        if args.compare:
            for path in args.dirs:
                print(compare_row(load_json(path, ResultsError, "compare JSON"), path.stem))
            return
        report = readings(args.dirs)
    except (ValueError, KeyError) as err:
        ap.error(str(err))
    print(json.dumps(report) if args.json else text(report))


if __name__ == "__main__":
    raise SystemExit(main())
