"""Benchmark one full DWA planning step (20 x 40 samples, tau = 5 s, 0.1 s resolution).

Scenes are random cluttered scans at the default beam count (240 deg at 0.5 deg). Prints
the median and p95 latency, and with --check also the agreement with the brute-force
reference (tests/support/reference_planner.py) and the lattice's deviation from continuous geometry.

    python -m tools.bench.bench_planner --json
    python -m tools.bench.bench_planner --check 1000
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence

import numpy as np

from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.planner import PlannerAction, plan
from d3dwa_bullet.sim.lidar import LidarParams
from tools.entry import ToolParser, tool_main


def random_scene(rng: np.random.Generator, beams: int) -> np.ndarray:
    """A cluttered scan as body-frame points: a room wall plus 2-10 blobs, (M, 2) m."""
    lidar = LidarParams()
    ang = -0.5 * lidar.fov + lidar.fov * np.arange(beams) / (beams - 1)
    r = np.full(beams, rng.uniform(1.5, 4.0))
    for _ in range(int(rng.integers(2, 11))):
        centre, half, dist = rng.uniform(-2, 2), rng.uniform(0.03, 0.4), rng.uniform(0.3, 2.5)
        r = np.where(np.abs(ang - centre) < half, np.minimum(r, dist), r)
    x0 = lidar.mount_x
    return np.column_stack((x0 + r * np.cos(ang), r * np.sin(ang)))


def bench(n: int, seed: int, tau: float) -> dict:
    rng = np.random.default_rng(seed)
    lidar = LidarParams()
    params = PlannerParams()
    action = PlannerAction(1.0, 1.0, 1.0, tau)
    scenes = [
        (
            random_scene(rng, lidar.beams),
            (rng.uniform(0, 0.4), rng.uniform(-1, 1)),
            rng.uniform(-1, 4, 2),
        )
        for _ in range(n)
    ]
    plan(scenes[0][1], scenes[0][0], scenes[0][2], action, params)  # warm-up
    times, cpu = [], []
    for pts, vel, goal in scenes:
        t0, c0 = time.perf_counter(), time.process_time()
        plan(vel, pts, goal, action, params)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    ms = np.asarray(times) * 1e3
    return {
        "median_ms": round(float(np.median(ms)), 3),
        "p95_ms": round(float(np.percentile(ms, 95)), 3),
        "cpu_mean_ms": round(float(np.mean(cpu)) * 1e3, 3),
        "samples": params.n_v * params.n_w,
        "horizon_s": tau,
        "beams": lidar.beams,
    }


def check(n: int, seed: int) -> dict:
    """Agreement with the brute-force reference over n random scenes, actions and states."""
    # tests/ is no dependency of the tool: only --check needs it (from the repository root)
    from tests.support.reference_planner import reference_plan

    rng = np.random.default_rng(seed)
    params = PlannerParams()
    beams = LidarParams().beams
    same, diffs, lattice_err = 0, [], []
    for _ in range(n):
        pts = random_scene(rng, beams)
        vel = (rng.uniform(0, 0.4), rng.uniform(-2, 2))
        goal = rng.uniform(-1, 4, 2)
        wp, wc, ws = (float(w) for w in rng.choice([1, 2, 3], 3))
        action = PlannerAction(wp, wc, ws, float(rng.choice([2, 3, 4, 5])))
        fast = plan(vel, pts, goal, action, params)
        _, _, ref_index, ref_clear, _ = reference_plan(vel, pts, goal, action, params)
        same += int(ref_index == fast.index)
        if ref_index >= 0:
            diffs.append(abs(fast.clearance[ref_index] - ref_clear[ref_index]))
            exact = _continuous_clearance(fast.samples[ref_index], pts, action.tau, params)
            lattice_err.append(abs(exact - fast.clearance[ref_index]))
    return {
        "scenes": n,
        "same_command_ratio": same / n,
        "max_clearance_diff_m": float(max(diffs)),
        "lattice_vs_continuous_max_m": float(max(lattice_err)),
        "lattice_vs_continuous_p95_m": float(np.percentile(lattice_err, 95)),
    }


def _continuous_clearance(
    sample: np.ndarray, pts: np.ndarray, tau: float, params: PlannerParams
) -> float:
    """Clearance of one sample with no lattice: exact circle-centre-to-point distances."""
    v, w = sample
    t = params.dt * np.arange(1, int(round(tau / params.dt)) + 1)
    th = w * t
    x = v * t * np.sinc(th / math.pi)
    y = v * t * np.sin(th / 2) * np.sinc(th / (2 * math.pi))
    best = params.clearance_cap
    for c in params.footprint.centers_x:
        q = np.column_stack((x + c * np.cos(th), y + c * np.sin(th)))
        d = np.hypot(q[:, None, 0] - pts[None, :, 0], q[:, None, 1] - pts[None, :, 1])
        best = min(best, float(d.min()))
    return best


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=500, help="timed planning steps")
    ap.add_argument("--tau", type=float, default=5.0, help="prediction horizon, s")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--check",
        type=int,
        default=0,
        metavar="N",
        help="also compare with the reference on N scenes",
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    out = bench(args.scenes, args.seed, args.tau)
    if args.check:
        out["check"] = check(args.check, args.seed + 1)
    if args.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:>12}: {v}")


if __name__ == "__main__":
    raise SystemExit(main())
