"""Evaluation throughput: episodes a minute on this machine's cores, per method family, with and
without the recovery layer, on R-style layouts and on BARN worlds (issue 55, part 4).

Each cell is one whole ``d3dwa sweep`` command, timed from start to end as a user runs it (start-up,
the episodes on ``--workers`` processes, the page and its figures), into a fresh directory:

    python -m tools.bench.bench_throughput --json
    python -m tools.bench.bench_throughput --layouts 1 --barn-ids 0,6 --quick   # a smoke test

The families: a fixed DWA (``dwa3``), the uniform chooser held for its decision period
(``random@10``) and a learned policy (``d3dwa``, training seed 0). Every world runs without noise
(a sweep's baseline) and under the ``real`` profile, one evaluation seed, as the yardstick sweep
does. R-style: ``--layouts`` fresh layouts per style (generator seeds 2^31 ..., the sweep's own).
BARN: the ``challenge`` worlds of ``--barn-ids``. A cell's rate counts its own episodes only;
``steps_per_s`` (control steps of 0.1 s simulated a wall second) is printed beside it, since an
episode's length depends on how it ends.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tools.entry import ToolParser, fail, tool_main

FAMILIES = {"fixed": "dwa3", "random held": "random@10", "learned": "d3dwa"}
"""Method family -> the method that stands for it."""

LAYERS = ("none", "nav2")
"""Without and with the recovery layer."""


def cell_argv(
    method: str, recovery: str, suite: str, out: Path, layouts: int, barn_ids: str, workers: int,
    time_limit: float | None = None,
) -> list[str]:  # fmt: skip
    """The ``d3dwa sweep`` command of one cell (suite: "R-style" or "BARN")."""
    worlds = (
        ["--worlds", "", "--styles", "R1-style,R2-style,R3-style", "--layouts", str(layouts)]
        if suite == "R-style"
        else ["--suite", "barn", "--split", "challenge", "--world-ids", barn_ids]
    )
    argv = [sys.executable, "-m", "d3dwa_bullet.cli", "sweep", *worlds, "--axes", "",
            "--profiles", "real", "--seeds", "1", "--recovery", recovery, "--methods", method,
            *(["--policy-seeds", "0"] if method == FAMILIES["learned"] else []),
            "--workers", str(workers), "--out", str(out)]  # fmt: skip
    if time_limit is not None:
        argv += ["--time-limit", str(time_limit)]
    return argv


def measure(argv: list[str], out: Path) -> dict[str, Any]:
    """Run one cell's command; its episodes, wall s, episodes a minute and steps a wall second."""
    start = time.perf_counter()
    try:
        subprocess.run(
            argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
    except subprocess.CalledProcessError as err:  # its own one line (a d3dwa error) is the why
        why = (err.stderr or "").strip().splitlines()[-1:] or [f"exit status {err.returncode}"]
        fail("bench_throughput", f"{' '.join(argv[2:])} failed: {why[0]}")
    wall = time.perf_counter() - start
    with open(out / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = sum(int(r["steps"]) for r in rows)
    return {
        "episodes": len(rows),
        "wall_s": round(wall, 2),
        "episodes_per_min": round(60.0 * len(rows) / wall, 1),
        "steps_per_s": round(steps / wall, 0),
        "goals": sum(r["outcome"] == "goal" for r in rows),
    }


def run(
    layouts: int, barn_ids: str, workers: int, time_limit: float | None, progress: bool = True
) -> list[dict[str, Any]]:
    """Every cell (suite x layer x family), each into its own fresh directory."""
    cells = []
    with tempfile.TemporaryDirectory() as tmp:
        for suite in ("R-style", "BARN"):
            for recovery in LAYERS:
                for family, method in FAMILIES.items():
                    out = Path(tmp) / f"{suite}-{recovery}-{method.replace('@', '_')}"
                    argv = cell_argv(method, recovery, suite, out, layouts, barn_ids, workers,
                                     time_limit)  # fmt: skip
                    cell = measure(argv, out)
                    cell = {"suite": suite, "recovery": recovery, "family": family,
                            "method": method} | cell  # fmt: skip
                    if progress:
                        print(json.dumps(cell), file=sys.stderr)
                    cells.append(cell)
    return cells


def table(cells: list[dict[str, Any]]) -> str:
    """The cells as a markdown table (episodes a minute, and steps a second beside)."""
    lines = ["| worlds | layer | family | episodes | wall s | episodes / min | steps / s |",
             "|---|---|---|---:|---:|---:|---:|"]  # fmt: skip
    for c in cells:
        lines.append(f"| {c['suite']} | {c['recovery']} | {c['family']} (`{c['method']}`) | "
                     f"{c['episodes']} | {c['wall_s']} | {c['episodes_per_min']} | "
                     f"{c['steps_per_s']:.0f} |")  # fmt: skip
    return "\n".join(lines)


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--layouts", type=int, default=4, help="fresh layouts per R style (default 4)")
    ap.add_argument(
        "--barn-ids",
        default="0,6,12,18,24,30,36,42,48,54,60,66",
        help="BARN challenge world ids (default: the first 12)",
    )
    ap.add_argument("--workers", type=int, default=2, help="processes per command (default 2)")
    ap.add_argument("--quick", action="store_true", help="10 s episode time limit (a smoke test)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.layouts < 1 or args.workers < 1:
        ap.error(f"--layouts and --workers must be >= 1, got {args.layouts} and {args.workers}")
    cells = run(args.layouts, args.barn_ids, args.workers, 10.0 if args.quick else None)
    info = {"cpus": os.cpu_count(), "load_avg_1m": round(os.getloadavg()[0], 2),
            "workers": args.workers, "profile": "real"}  # fmt: skip
    print(json.dumps(info | {"cells": cells}) if args.json else table(cells))


if __name__ == "__main__":
    raise SystemExit(main())
