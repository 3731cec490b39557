"""Benchmark the sweep's parallel speed-up: the same small sweep with 1 and with N workers.

Both runs write fresh results directories and must give identical rows (compared
order-independently, ``identical_rows``) and, once complete, the same results.csv bytes
(``identical_csv_bytes``: a complete run is rewritten in job order); the speed-up is t1 / tN of the wall-clock times. Other work on the
cores (e.g. a training run) lowers it, so the load average is reported, and so is the CPU
time each run got (this process plus its finished workers): ``cpu_util`` = CPU s / wall s
is about 1 for one worker and about N for N workers on idle cores, whatever the episodes.

    python -m tools.bench.bench_sweep --json   # {"t1_s", "t2_s", "speedup", ...}
    python -m tools.bench.bench_sweep --quick  # 10 s episodes, for a smoke test
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation.results import CSV_FIELDS
from d3dwa_bullet.evaluation.sweep import SweepSettings, read_sweep, run_sweep
from tools.entry import ToolParser, tool_main

#: The benchmark's sweep: 3 methods x 3 worlds (R1, R2, one unseen R1-style layout) x 3
#: noise conditions (none, lidar dropout 0.5, the `real` profile) = 27 episodes.
SETTINGS: dict[str, Any] = dict(
    methods=("dwa1", "dwa2", "dwa3"),
    worlds=("R1", "R2"),
    styles=("R1-style",),
    layouts=1,
    seeds=1,
    levels=1,
    axes=("lidar_dropout",),
    profiles=("none", "real"),
)


def rows_signature(out: Path) -> list[tuple]:
    """The sorted rows of a sweep (everything but the row order)."""
    keys = [*CSV_FIELDS, "axis", "level", "layout"]
    return sorted(tuple(str(r[k]) for k in keys) for r in read_sweep(out))


def cpu_seconds() -> float:
    """CPU time of this process and its terminated, waited-for children (pool workers), s."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def run(workers: int = 2, time_limit: float | None = None, root: str | None = None) -> dict:
    """Time the sweep with 1 and with `workers` workers; returns the measurements."""
    settings = SweepSettings(**SETTINGS, time_limit=time_limit)
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        times, cpu = {}, {}
        load_before = os.getloadavg()[0]
        for n in (1, workers):
            out = Path(tmp) / f"w{n}"
            t0, c0 = time.perf_counter(), cpu_seconds()
            run_sweep(settings, out, workers=n, config=EpisodeConfig(), progress=False)
            times[n], cpu[n] = time.perf_counter() - t0, cpu_seconds() - c0
        load_after = os.getloadavg()[0]
        identical = rows_signature(Path(tmp) / "w1") == rows_signature(Path(tmp) / f"w{workers}")
        csv_1, csv_n = (Path(tmp) / f"w{n}" / "results.csv" for n in (1, workers))
        same_bytes = csv_1.read_bytes() == csv_n.read_bytes()
        episodes = len(read_sweep(Path(tmp) / "w1"))
    return {
        "t1_s": round(times[1], 1),
        f"t{workers}_s": round(times[workers], 1),
        "speedup": round(times[1] / times[workers], 2),
        "cpu_util_1": round(cpu[1] / times[1], 2),
        f"cpu_util_{workers}": round(cpu[workers] / times[workers], 2),
        "workers": workers,
        "episodes": episodes,
        "identical_rows": identical,
        "identical_csv_bytes": same_bytes,
        "cpus": os.cpu_count(),
        "load_avg_1m_before": round(load_before, 2),
        "load_avg_1m_after": round(load_after, 2),
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2, help="the parallel run's workers")
    ap.add_argument("--quick", action="store_true", help="10 s episode time limit")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    out = run(args.workers, 10.0 if args.quick else None)
    print(json.dumps(out) if args.json else "\n".join(f"{k:>20}: {v}" for k, v in out.items()))


if __name__ == "__main__":
    raise SystemExit(main())
