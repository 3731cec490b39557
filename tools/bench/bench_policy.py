"""Policy inference latency: one 12-d observation -> one action, per shipped policy.

Loads each learned method's shipped checkpoint (``policies/<method>``, or --policy for one
method) and times single calls on random observations in [0, 1] (angles in [-1, 1]), after
a warm-up. Prints the median and p95 per method.

    python -m tools.bench.bench_policy --json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.methods import LEARNED, one_policy


def bench(method: str, path, calls: int, seed: int) -> dict:
    policy, _, _ = load_policy(path, expected_actions=LEARNED[method])
    rng = np.random.default_rng(seed)
    obs = rng.uniform(0.0, 1.0, (calls, 12))
    obs[:, 1:4] = rng.uniform(-1.0, 1.0, (calls, 3))  # heading, v and w are signed
    for o in obs[:50]:
        policy(o)
    times = np.empty(calls)
    for k, o in enumerate(obs):
        t0 = time.perf_counter()
        policy(o)
        times[k] = time.perf_counter() - t0
    ms = times * 1e3
    return {
        "median_ms": round(float(np.median(ms)), 4),
        "p95_ms": round(float(np.percentile(ms, 95)), 4),
        "calls": calls,
    }


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--methods", default=",".join(LEARNED), help="comma list of learned methods")
    ap.add_argument("--policy", help="checkpoint directory (only with a single --methods)")
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    methods = args.methods.split(",")
    if args.policy and len(methods) != 1:
        ap.error("--policy needs exactly one --methods")
    out = {m: bench(m, one_policy(m, args.policy)[0], args.calls, args.seed) for m in methods}
    if args.json:
        print(json.dumps(out))
    else:
        for m, r in out.items():
            print(f"{m:>14}: median {r['median_ms']} ms, p95 {r['p95_ms']} ms ({r['calls']} calls)")


if __name__ == "__main__":
    main()
