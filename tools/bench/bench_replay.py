"""Benchmark ``d3dwa replay`` end to end: bag -> observation -> policy -> planner -> CSV.

Without ``--bag`` a bag is recorded first (one whole episode, R3 with the ``real`` noise
profile by default) into a temporary directory. Each timed run is the full replay of that
bag as the CLI does it: open and read the bag, build every observation, ask the policy,
plan, and write replay.csv and summary.json (figures off unless ``--plots``; they are a
fixed cost per bag, not per scan). Loading the policy is not timed.

The policy is the method's shipped checkpoint (``policies/<method>``) or ``--policy``; if
neither exists, an untrained D3QN of the same shape stands in (same cost per scan).

    python -m tools.bench.bench_replay --json
    python -m tools.bench.bench_replay --bag my_run/ --method dwa3 --repeats 5

``scans_per_s`` is the best of ``--repeats`` runs (like ``timeit``: the run least disturbed
by other load on the machine); the median and the CPU-time rate are printed too. It includes
opening the bag, a fixed cost per bag (rosbags parses metadata.yaml and compiles a decoder
per message type: ``read_s``) that a short bag cannot amortise; ``decide_scans_per_s`` is
the per-scan pipeline alone (observation, estimator, policy, planner, CSV row).
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from d3dwa_bullet.controllers import default_policy_path, one_policy
from d3dwa_bullet.method_specs import LEARNED, needs_policy
from tools.entry import ToolParser, tool_main
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.sim_bridge import make_step_fn, record_episode


def stand_in_policy(method: str, directory: Path) -> Path:
    """An untrained D3QN checkpoint with the method's action set (default network shape)."""
    # start-up cost: torch (~1 s) is needed only when no checkpoint exists to replay with
    from d3dwa_bullet.learning.agents import D3QNAgent, save_checkpoint

    return save_checkpoint(directory / method, D3QNAgent(LEARNED[method]), method=method)


def bench(
    bag: Path, method: str, policy: Path | None, repeats: int, plots: bool, work: Path
) -> dict:
    step_fn = make_step_fn(method, policy)
    walls, cpus, reads, decides, scans = [], [], [], [], 0
    for k in range(repeats):
        out = work / f"out{k}"
        t0, c0 = time.perf_counter(), time.process_time()
        result = replay_bag(bag, step_fn=step_fn, out_dir=out, plots=plots)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        reads.append(result.timing["read"])
        decides.append(result.timing["decide"])
        scans = result.replayed
    return {
        "scans_per_s": round(scans / min(walls), 1),
        "scans": scans,
        "median_scans_per_s": round(scans / statistics.median(walls), 1),
        "cpu_scans_per_s": round(scans / min(cpus), 1),
        "decide_scans_per_s": round(scans / min(decides), 1),
        "read_s": round(min(reads), 3),
        "repeats": repeats,
        "method": method,
        "policy": str(policy) if policy else "fixed",
        "bag": str(bag),
        "plots": plots,
    }


@tool_main
def main(argv: list[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bag", type=Path, help="bag to replay (default: record one)")
    ap.add_argument("--world", default="R3", help="world of the recorded episode")
    ap.add_argument("--noise", default="real", help="noise profile of the recorded episode")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--method", default="d3dwa", help="replay method (default: d3dwa)")
    ap.add_argument("--policy", type=Path, help="checkpoint (default: shipped or stand-in)")
    ap.add_argument("--repeats", type=int, default=3, help="timed replays of the bag")
    ap.add_argument("--plots", action="store_true", help="time the figures too")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory(prefix="bench_replay_") as tmp:
        work = Path(tmp)
        policy = args.policy
        if policy is None and needs_policy(args.method):
            shipped = default_policy_path(args.method)
            policy = (
                one_policy(args.method)[0]
                if shipped.exists()
                else stand_in_policy(args.method, work)
            )
        bag = args.bag
        if bag is None:
            bag = work / f"{args.world}_{args.noise}"
            with BagRecorder(bag) as rec:
                record_episode(args.world, args.method, policy, args.noise, args.seed, rec)
        report = bench(bag, args.method, policy, max(1, args.repeats), args.plots, work)
    if args.bag is None:
        report["bag"] = f"recorded {args.world}, noise {args.noise}, seed {args.seed}"
    if args.json:
        print(json.dumps(report))
    else:
        print(
            f"{report['scans']} scans ({report['bag']}), {report['method']}: "
            f"{report['scans_per_s']} scans/s best of {report['repeats']}, "
            f"median {report['median_scans_per_s']}, CPU-time rate {report['cpu_scans_per_s']}; "
            f"opening the bag {report['read_s']} s, per-scan pipeline alone "
            f"{report['decide_scans_per_s']} scans/s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
