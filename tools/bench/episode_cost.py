"""Episode cost in PyBullet against a baseline commit, in one run, and the same episodes (issue 78).

For each family (BARN ``challenge`` worlds, fresh R-style layouts) and each ``--workers`` count, one
``d3dwa sweep`` command runs under this tree (A) and under the baseline (B: ``git archive`` of
``--baseline``, imported first through PYTHONPATH), in turn, each into a fresh directory. The CPU
of a command is the operating system's user + system seconds of it and every process it waited
for (``RUSAGE_CHILDREN``), start-up and the sweep's page included; a load-independent figure on a
shared machine, unlike wall time. Every results row and every per-step log of A is compared with
B's: ``same_episodes`` is true only if all are equal bit for bit::

    python -m tools.bench.episode_cost --json                      # against 9fc0444
    python -m tools.bench.episode_cost --barn-ids 0 --layouts 1 --workers 1   # a smoke test
    python -m tools.bench.episode_cost --families BARN --workers 1 --json     # BARN alone

``episodes_per_core_min`` = episodes / (CPU s / 60); ``cpu_ratio`` = B's CPU / A's (above 1: A is
cheaper); ``workers_speedup`` = wall of 1 worker / wall of N, per tree, which only means something
on an otherwise idle machine (the load average is printed beside it).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tools.entry import ToolParser, fail, tool_main

ROOT = Path(__file__).resolve().parents[2]
FAMILIES = ("BARN", "R-style")


def baseline_tree(commit: str, into: Path) -> Path:
    """``git archive`` of commit (of this checkout's repository) unpacked into ``into``."""
    done = subprocess.run(["git", "-C", str(ROOT), "archive", commit], capture_output=True)
    if done.returncode != 0:
        first = (done.stderr.decode(errors="replace").strip().splitlines() or ["failed"])[0]
        fail("episode_cost", f"--baseline {commit}: git archive: {first}")
    into.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(done.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def sweep_argv(family: str, args: argparse.Namespace, workers: int, out: Path) -> list[str]:
    """The ``d3dwa sweep`` command of one family."""
    worlds = (
        ["--suite", "barn", "--split", "challenge", "--world-ids", args.barn_ids]
        if family == "BARN"
        else [
            "--worlds",
            "",
            "--styles",
            "R1-style,R2-style,R3-style",
            "--layouts",
            str(args.layouts),
        ]
    )
    return [sys.executable, "-m", "d3dwa_bullet.cli", "sweep", *worlds, "--axes", "",
            "--profiles", args.profiles, "--seeds", "1", "--recovery", args.recovery,
            "--methods", args.methods, "--policy-seeds", "0", "--workers", str(workers),
            "--out", str(out)]  # fmt: skip


def timed(argv: list[str], tree: Path | None, out: Path) -> dict[str, Any]:
    """Run one command (under ``tree`` first on the path, if given): episodes, CPU s, wall s."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(tree), *filter(None, [env.get("PYTHONPATH")])])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=tempfile.gettempdir(), capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        why = (done.stderr or "").strip().splitlines()[-1:] or [f"exit status {done.returncode}"]
        fail("episode_cost", f"{' '.join(argv[3:])} failed: {why[0]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with open(out / "results.csv", newline="") as f:
        episodes = sum(1 for _ in csv.DictReader(f))
    return {
        "episodes": episodes,
        "cpu_s": round(cpu, 2),
        "wall_s": round(wall, 2),
        "episodes_per_core_min": round(60.0 * episodes / cpu, 2),
    }


def same_episodes(a: Path, b: Path) -> tuple[bool, str]:
    """(equal, what differs first) of two results directories: rows (as sets of lines) and logs."""
    rows_a = sorted((a / "results.csv").read_text().splitlines())
    rows_b = sorted((b / "results.csv").read_text().splitlines())
    if rows_a != rows_b:
        first = next((x for x, y in zip(rows_a, rows_b, strict=False) if x != y), "row count")
        return False, f"results.csv differs: {first}"
    logs_a = sorted(p.name for p in (a / "logs").glob("*.npz"))
    if logs_a != sorted(p.name for p in (b / "logs").glob("*.npz")):
        return False, "the logs' names differ"
    for name in logs_a:
        with np.load(a / "logs" / name) as la, np.load(b / "logs" / name) as lb:
            if sorted(la.files) != sorted(lb.files):
                return False, f"{name}: columns differ"
            for key in la.files:
                if not np.array_equal(la[key], lb[key]):
                    return False, f"{name}: column {key} differs"
    return True, f"{len(rows_a)} rows and {len(logs_a)} logs equal"


def run(args: argparse.Namespace, tmp: Path) -> list[dict[str, Any]]:
    """Every (family, workers) cell: A then B, compared."""
    base = baseline_tree(args.baseline, tmp / "baseline")
    cells = []
    for family in args.families:
        for workers in args.workers:
            outs = {name: tmp / f"{family}-w{workers}-{name}" for name in ("A", "B")}
            a = timed(sweep_argv(family, args, workers, outs["A"]), None, outs["A"])
            b = timed(sweep_argv(family, args, workers, outs["B"]), base, outs["B"])
            same, why = same_episodes(outs["A"], outs["B"])
            cell = {"family": family, "workers": workers, "A": a, "B": b,
                    "cpu_ratio": round(b["cpu_s"] / a["cpu_s"], 3), "same_episodes": same,
                    "compared": why, "load_avg_1m": round(os.getloadavg()[0], 2)}  # fmt: skip
            print(json.dumps(cell), file=sys.stderr, flush=True)
            cells.append(cell)
    for family in FAMILIES:
        one = next((c for c in cells if c["family"] == family and c["workers"] == 1), None)
        for c in cells:
            if one is not None and c["family"] == family and c["workers"] > 1:
                c["workers_speedup"] = {
                    t: round(one[t]["wall_s"] / c[t]["wall_s"], 3) for t in ("A", "B")
                }
    return cells


def table(cells: list[dict[str, Any]], baseline: str) -> str:
    """The cells as a markdown table."""
    lines = [f"B = {baseline}. CPU ratio = B / A; speed-up = wall of 1 worker / wall of N.", "",
             "| family | workers | episodes | CPU s A / B | episodes per core-min A / B | CPU ratio "
             "| speed-up A / B | same episodes |",
             "|---|---:|---:|---:|---:|---:|---:|---|"]  # fmt: skip
    for c in cells:
        a, b = c["A"], c["B"]
        up = c.get("workers_speedup")
        speedup = f"{up['A']} / {up['B']}" if up else "-"
        lines.append(
            f"| {c['family']} | {c['workers']} | {a['episodes']} | {a['cpu_s']} / {b['cpu_s']} | "
            f"{a['episodes_per_core_min']} / {b['episodes_per_core_min']} | {c['cpu_ratio']} | "
            f"{speedup} | {c['same_episodes']} |"
        )
    return "\n".join(lines)


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--baseline", default="9fc0444", help="commit to compare with (default 9fc0444)"
    )
    ap.add_argument(
        "--families", default=",".join(FAMILIES), help="comma list (default %(default)s)"
    )
    ap.add_argument("--barn-ids", default="0,150", help="BARN challenge world ids (default 0,150)")
    ap.add_argument("--layouts", type=int, default=1, help="fresh layouts per R style (default 1)")
    ap.add_argument("--methods", default="dwa3,d3dwa", help="comma list (default dwa3,d3dwa)")
    ap.add_argument("--profiles", default="none,harsh", help="noise profiles (default none,harsh)")
    ap.add_argument("--recovery", default="nav2", help="recovery layer (default nav2)")
    ap.add_argument("--workers", default="1,2", help="worker counts, comma list (default 1,2)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        args.workers = [int(w) for w in args.workers.split(",")]
    except ValueError:
        ap.error(f"--workers must be a comma list of integers >= 1, got {args.workers!r}")
    args.families = [f for f in args.families.split(",") if f]
    unknown = [f for f in args.families if f not in FAMILIES]
    if unknown or not args.families:
        got = ",".join(unknown) or "none"
        ap.error(f"--families must be a comma list of {', '.join(FAMILIES)}, got {got}")
    if args.layouts < 1 or min(args.workers) < 1:
        ap.error(f"--layouts and --workers must be >= 1, got {args.layouts} and {args.workers}")
    with tempfile.TemporaryDirectory(prefix="episode_cost-") as tmp:
        cells = run(args, Path(tmp))
    info = {"cpus": os.cpu_count(), "load_avg_1m": round(os.getloadavg()[0], 2),
            "baseline": args.baseline, "methods": args.methods, "profiles": args.profiles,
            "recovery": args.recovery}  # fmt: skip
    print(json.dumps(info | {"cells": cells}) if args.json else table(cells, args.baseline))


if __name__ == "__main__":
    raise SystemExit(main())
