"""Estimator accuracy: raw wheel odometry vs the EKF, against ground truth, on a fixed route.

One world, one fixed method, one noise profile, several seeds. Every control step, after the
robot has moved, three poses are sampled: ground truth (``Simulator.true_pose``), raw wheel
odometry (``Simulator.odometry_pose``) and the EKF (``Simulator.estimate``). The robot
plans on the EKF, as it always does with noise on, so the route is the closed-loop one.
RMSEs pool every sample of every seed (each step weighs the same); the per-seed values are
reported too, since the issue-3 target (EKF position RMSE <= half the odometry's) should
hold seed by seed, not only on average.

    python -m tools.bench.eval_estimator --json  # TS1, dwa3, `real`, seeds 0..4
    python -m tools.bench.eval_estimator --world H3 --seeds 8 --profile harsh
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, run_episode
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.planning.planner import PlannerAction, PlanResult
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, fail, tool_main

#: The issue-3 target: EKF position RMSE at most this fraction of raw odometry's.
TARGET_RATIO = 0.5


@dataclass(frozen=True)
class Args:
    """What to drive and under which noise."""

    world: str = "TS1"
    """World name or file: the route is its start -> goal."""
    method: str = "dwa3"
    """A fixed method (dwa1, dwa2, dwa3) so the controller is the same for every seed."""
    profile: str = "real"
    """Randomisation profile (none, paper, real, harsh) or a YAML path."""
    seed: int = 0
    """First episode seed."""
    seeds: int = 5
    """Number of seeds: seed, seed + 1, ..."""
    time_limit: float | None = None
    """Episode time limit, s (default: the world's, 60 s)."""
    json: bool = False
    """Print one JSON object instead of a table."""


@dataclass
class Track:
    """Poses sampled once per control step: (steps, 3) each, x, y in m, yaw in rad."""

    truth: list[tuple[float, float, float]]
    odometry: list[tuple[float, float, float]]
    ekf: list[tuple[float, float, float]]

    def sample(self, ep: Episode, index: int, action: PlannerAction, plan: PlanResult) -> None:
        """``run_episode``'s ``on_step`` hook: runs right after the robot has moved."""
        sim = ep.sim
        self.truth.append(sim.true_pose())
        self.odometry.append(sim.odometry_pose())
        self.ekf.append(sim.estimate()[0])


def position_errors(poses: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Euclidean position error per sample: poses, truth (N, 3) -> (N,), m."""
    return np.hypot(poses[:, 0] - truth[:, 0], poses[:, 1] - truth[:, 1])


def yaw_errors(poses: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Wrapped heading error per sample: (N, 3), (N, 3) -> (N,), rad in [-pi, pi)."""
    return np.remainder(poses[:, 2] - truth[:, 2] + np.pi, 2.0 * np.pi) - np.pi


def rmse(errors: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(errors)))) if errors.size else math.nan


def run(
    world: str = "TS1",
    method: str = "dwa3",
    profile: str = "real",
    seeds: Sequence[int] = range(5),
    time_limit: float | None = None,
) -> dict[str, Any]:
    """Drive the route once per seed and compare odometry and EKF with ground truth.

    Returns ``odom_rmse_m``, ``ekf_rmse_m``, ``ekf_yaw_rmse_rad`` (pooled over all steps of
    all seeds), ``seeds``, plus ``odom_yaw_rmse_rad``, ``ratio`` (EKF / odometry position
    RMSE), ``target_met`` (ratio <= 0.5 pooled *and* for every seed), the sample count and
    a ``per_seed`` list with each episode's outcome and RMSEs.
    """
    w = load_world(world)
    if time_limit is not None:
        w = w.with_task(time_limit=time_limit)
    controller = make_controller(method)
    if controller.fixed is None:
        raise D3DWAError(f"eval_estimator drives a fixed method (dwa1/dwa2/dwa3), got {method!r}")
    per_seed: list[dict[str, Any]] = []
    pooled: dict[str, list[np.ndarray]] = {"odom": [], "ekf": [], "odom_yaw": [], "ekf_yaw": []}
    for seed in seeds:
        track = Track([], [], [])
        result = run_episode(
            w, controller, seed=seed, noise=make_noise(profile, seed), noise_name=profile,
            on_step=track.sample,
        )  # fmt: skip
        truth, odom, ekf = (np.asarray(t, dtype=np.float64).reshape(-1, 3) for t in (
            track.truth, track.odometry, track.ekf))  # fmt: skip
        errs = {
            "odom": position_errors(odom, truth),
            "ekf": position_errors(ekf, truth),
            "odom_yaw": yaw_errors(odom, truth),
            "ekf_yaw": yaw_errors(ekf, truth),
        }
        for key, e in errs.items():
            pooled[key].append(e)
        odom_rmse, ekf_rmse = rmse(errs["odom"]), rmse(errs["ekf"])
        per_seed.append(
            {
                "seed": int(seed),
                "outcome": result.outcome,
                "steps": len(truth),
                "odom_rmse_m": round(odom_rmse, 4),
                "ekf_rmse_m": round(ekf_rmse, 4),
                "odom_yaw_rmse_rad": round(rmse(errs["odom_yaw"]), 4),
                "ekf_yaw_rmse_rad": round(rmse(errs["ekf_yaw"]), 4),
                "odom_final_error_m": round(float(errs["odom"][-1]), 4) if len(truth) else None,
                "ratio": round(ekf_rmse / odom_rmse, 3) if odom_rmse > 0 else None,
            }
        )
    all_errs = {k: np.concatenate(v) if v else np.zeros(0) for k, v in pooled.items()}
    odom_rmse, ekf_rmse = rmse(all_errs["odom"]), rmse(all_errs["ekf"])
    ratio = ekf_rmse / odom_rmse if odom_rmse > 0 else math.inf
    return {
        "odom_rmse_m": round(odom_rmse, 4),
        "ekf_rmse_m": round(ekf_rmse, 4),
        "ekf_yaw_rmse_rad": round(rmse(all_errs["ekf_yaw"]), 4),
        "odom_yaw_rmse_rad": round(rmse(all_errs["odom_yaw"]), 4),
        "seeds": [int(s) for s in seeds],
        "ratio": round(ratio, 3),
        "target_met": bool(
            ratio <= TARGET_RATIO
            and all(r["ratio"] is not None and r["ratio"] <= TARGET_RATIO for r in per_seed)
        ),
        "world": w.name,
        "method": method,
        "profile": profile,
        "samples": int(all_errs["odom"].size),
        "per_seed": per_seed,
    }


def parse_args(argv: Sequence[str] | None = None) -> Args:
    ap = ToolParser(description=__doc__.split("\n\n")[0])
    for f in fields(Args):
        flag = "--" + f.name.replace("_", "-")
        if f.type == "bool":
            ap.add_argument(flag, action="store_true")
        else:
            kind = {"int": int, "str": str}.get(str(f.type), float)
            ap.add_argument(flag, type=kind, default=f.default)
    return Args(**vars(ap.parse_args(argv)))


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.seeds < 1:
        print("eval_estimator: error: --seeds must be >= 1", file=sys.stderr)
        return 2
    try:
        out = run(
            args.world,
            args.method,
            args.profile,
            range(args.seed, args.seed + args.seeds),
            args.time_limit,
        )
    except D3DWAError as err:
        fail("eval_estimator", str(err))
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{out['world']} {out['method']} under `{out['profile']}`, {out['samples']} samples")
    print(f"{'seed':>4} {'outcome':<9} {'steps':>5} {'odom m':>8} {'ekf m':>8} {'ratio':>6} "
          f"{'odom rad':>9} {'ekf rad':>8}")  # fmt: skip
    for r in out["per_seed"]:
        print(
            f"{r['seed']:>4} {r['outcome']:<9} {r['steps']:>5} {r['odom_rmse_m']:>8.4f} "
            f"{r['ekf_rmse_m']:>8.4f} {r['ratio'] if r['ratio'] is not None else math.nan:>6.3f} "
            f"{r['odom_yaw_rmse_rad']:>9.4f} {r['ekf_yaw_rmse_rad']:>8.4f}"
        )
    print(
        f" all {'':<9} {out['samples']:>5} {out['odom_rmse_m']:>8.4f} {out['ekf_rmse_m']:>8.4f} "
        f"{out['ratio']:>6.3f} {out['odom_yaw_rmse_rad']:>9.4f} {out['ekf_yaw_rmse_rad']:>8.4f}"
    )
    print(f"target (EKF <= {TARGET_RATIO} x odometry, pooled and per seed): "
          f"{'met' if out['target_met'] else 'MISSED'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
