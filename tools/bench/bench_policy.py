"""Policy inference latency: one observation -> one greedy action, per backend and method.

For each learned method's shipped policy (its lowest seed; ``--policy`` for one method) it
times single calls of each backend a robot could run:

  numpy        ``load_policy``'s policy (evaluation's: the advantage head in float32 numpy)
  torch        ``D3QNAgent.act(obs, greedy=True)``: the network's forward pass and argmax
  onnxruntime  the policy exported to ONNX, run by ``load_onnx_policy`` (no torch)

(the tabular dqdwa has the numpy one only). The backends take turns call by call on the same
observations (sampled in their entries' ranges), after a warm-up, so a load that comes and
goes during the run weighs on all of them alike. Prints p50 and p99 per call in ms.

    python -m tools.bench.bench_policy --json
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.controllers import one_policy
from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.onnx_export import export_onnx, sample_observations
from d3dwa_bullet.learning.agents.onnx_policy import load_onnx_policy
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.method_specs import LEARNED, method_observation
from tools.entry import ToolParser, tool_main

WARM_UP = 100


def backends(
    method: str, path: Path, scratch: Path
) -> tuple[dict[str, Callable[[np.ndarray], int]], tuple[str, ...]]:
    """(backend name -> a greedy policy of the checkpoint at ``path``, observation layout)."""
    kind = (method_observation(method), f"method {method!r}")
    policy, _, _ = load_policy(path, expected_actions=LEARNED[method], expected_observation=kind)
    out: dict[str, Callable[[np.ndarray], int]] = {"numpy": policy}
    agent, _ = load_checkpoint(path, expected_layout=None)
    if isinstance(agent, D3QNAgent):
        out["torch"] = lambda obs: agent.act(obs, greedy=True)
        file = export_onnx(path, scratch / f"{method}.onnx").file
        out["onnxruntime"], _, _ = load_onnx_policy(file, expected_observation=kind)
    return out, tuple(agent.obs_layout)


def bench(method: str, path: Path, calls: int, seed: int, scratch: Path) -> dict:
    policies, layout = backends(method, path, scratch)
    obs = sample_observations(layout, calls + WARM_UP, seed).astype(np.float64)
    names = list(policies)
    times = {name: np.empty(calls) for name in names}
    for k, o in enumerate(obs):
        for j in range(len(names)):
            name = names[(k + j) % len(names)]  # each backend in every position of the turn
            t0 = time.perf_counter()
            policies[name](o)
            elapsed = time.perf_counter() - t0
            if k >= WARM_UP:
                times[name][k - WARM_UP] = elapsed
    return {
        name: {
            "p50_ms": round(float(np.percentile(t * 1e3, 50)), 4),
            "p99_ms": round(float(np.percentile(t * 1e3, 99)), 4),
            "calls": calls,
        }
        for name, t in times.items()
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", default=",".join(LEARNED), help="comma list of learned methods")
    ap.add_argument("--policy", help="checkpoint directory (only with a single --methods)")
    ap.add_argument("--calls", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    methods = args.methods.split(",")
    if args.policy and len(methods) != 1:
        ap.error("--policy needs exactly one --methods")
    out: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as scratch:
        for m in methods:
            try:
                path = one_policy(m, args.policy)[0]
            except CheckpointError as err:  # e.g. a method with no shipped policy yet
                out[m] = {"skipped": str(err)}
                continue
            out[m] = bench(m, path, args.calls, args.seed, Path(scratch))
    if args.json:
        print(json.dumps(out))
        return
    for m, r in out.items():
        if "skipped" in r:
            print(f"{m:>14}: skipped ({r['skipped']})")
            continue
        for name, f in r.items():
            print(
                f"{m:>14} {name:>11}: p50 {f['p50_ms']} ms, p99 {f['p99_ms']} ms ({f['calls']} calls)"
            )


if __name__ == "__main__":
    raise SystemExit(main())
