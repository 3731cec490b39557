"""Benchmark the live loop over localhost gRPC: scan in, command out.

Starts ``d3dwa serve --realtime`` in its own process (physics steps there, at 10 Hz, as on a
robot), then runs ``d3dwa drive``'s loop against it for ``--steps`` steps per method and
reports the loop latency per step (read scan + odometry + wheel odometry + IMU, judge,
estimate, observe, choose, plan, send the command and get its answer): p50, p99, max. Also the
bare round trips: one step's reads, one command. Unpaced by default (the loop runs as fast as
it can, so many steps are measured in seconds; ``--paced`` runs it at the control rate, as
``d3dwa drive`` does on a robot). The target: p99 <= 20 ms.

``d3dwa-onnx`` is ``d3dwa`` with its shipped seed-0 checkpoint exported to ONNX and run by
onnxruntime (``drive --onnx``), beside the torch one.

    python -m tools.bench.bench_live --json
    python -m tools.bench.bench_live --methods dwa3,d3dwa,d3dwa-onnx --steps 2000 --json
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.learning.agents.onnx_export import export_onnx
from d3dwa_bullet.live import DriveResult, DriveSettings, KachakaLink, drive, warm_up
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.resources import policies_dir
from tools.entry import ToolParser, tool_main
from transfer.sim_bridge import ReplayPipeline

#: A long corridor: the robot does not reach the goal while the loop is measured.
WORLD, GOAL = "H3", (10.0, 0.0)


def percentiles(samples: list[float]) -> dict[str, float]:
    ms = np.asarray(samples) * 1e3
    return {
        "p50_ms": round(float(np.percentile(ms, 50)), 2),
        "p99_ms": round(float(np.percentile(ms, 99)), 2),
        "max_ms": round(float(ms.max()), 2),
        "n": int(ms.size),
    }


def serve() -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "d3dwa_bullet.cli", "serve", "--world", WORLD, "--port", "0"],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    found = re.search(r"on (\S+:\d+)", proc.stdout.readline())
    if not found:
        proc.kill()
        raise SystemExit("d3dwa serve did not start")
    return proc, found[1]


def controller(method: str, scratch: Path) -> Controller:
    """The method's controller; ``d3dwa-onnx``: d3dwa's seed 0 exported and run on onnxruntime."""
    if method != "d3dwa-onnx":
        return make_controller(method)
    exported = export_onnx(policies_dir() / "d3dwa" / "seed-0", scratch / "d3dwa.onnx")
    return make_controller("d3dwa", onnx=exported.file)


def bench_method(address: str, method: str, steps: int, paced: bool, scratch: Path) -> dict:
    pipeline = ReplayPipeline(controller(method, scratch))
    warm_up(pipeline)
    link = KachakaLink(address, timeout=2.0)
    try:
        reads = []
        for _ in range(200):
            t = time.perf_counter()
            link.read()
            reads.append(time.perf_counter() - t)
        commands = []
        for _ in range(200):
            t = time.perf_counter()
            link.command(0.0, 0.0)
            commands.append(time.perf_counter() - t)
        result = DriveResult()
        settings = DriveSettings(
            goal=GOAL, time_limit=steps / 10.0, lockstep=not paced, watchdog_s=5.0
        )
        drive(link, pipeline, settings, result=result)
    finally:
        link.close()
    return {
        "method": method,
        "loop": percentiles(result.latencies),
        "read_rpc": percentiles(reads),
        "command_rpc": percentiles(commands),
        "outcome": result.outcome,
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--methods", default="dwa3,d3dwa,d3dwa-onnx", help="comma list of methods (+ d3dwa-onnx)"
    )
    ap.add_argument("--steps", type=int, default=1000, help="loop steps per method")
    ap.add_argument("--paced", action="store_true", help="run the loop at the control rate")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    runs = []
    with tempfile.TemporaryDirectory() as scratch:
        for method in args.methods.split(","):
            proc, address = serve()  # a fresh robot per method: each starts at the world's start
            try:
                runs.append(bench_method(address, method, args.steps, args.paced, Path(scratch)))
            finally:
                proc.terminate()
                proc.wait()
    out = {"world": WORLD, "paced": args.paced, "target_p99_ms": 20.0, "runs": runs}
    if args.json:
        print(json.dumps(out))
        return
    for r in runs:
        loop = r["loop"]
        print(
            f"{r['method']:>8}: loop p50 {loop['p50_ms']} ms, p99 {loop['p99_ms']} ms, max "
            f"{loop['max_ms']} ms over {loop['n']} steps; reads p50 {r['read_rpc']['p50_ms']} "
            f"ms, command p50 {r['command_rpc']['p50_ms']} ms"
        )


if __name__ == "__main__":
    raise SystemExit(main())
