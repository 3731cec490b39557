"""Throughput of the training loop: env steps/s and D3QN gradient updates/s.

    python -m tools.bench.bench_train --json
    {"env_steps_per_s": ..., "updates_per_s": ..., "loop_steps_per_s": ..., ...}

Runs ``train()`` for a short budget (default 2000 control steps on the committed d3dwa
config: TS1-TS4 + generated R-style layouts, 128x128 dueling network, one update per
``train_freq`` steps) into a temporary directory, without evaluation or intermediate
checkpoints. env_steps_per_s counts time inside ``env.step`` only (plan + physics +
sensing + observation); updates_per_s counts gradient steps per second of
``agent.learn``; loop_steps_per_s is the whole loop (what bounds a training's length).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from d3dwa_bullet.learning.training import load_train_config, train
from d3dwa_bullet.resources import configs_dir


def run(steps: int = 2000, config: str | Path | None = None) -> dict:
    """Train ``steps`` control steps and return the throughput figures."""
    base = load_train_config(configs_dir() / "d3dwa.yaml" if config is None else config)
    agent = replace(base.agent, learning_starts=min(base.agent.learning_starts, steps // 4))
    cfg = replace(base, total_steps=steps, agent=agent, eval_every=0, checkpoint_every=0,
                  keep="final")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        s = train(cfg, Path(tmp) / "bench", progress=False)
    t = s["timing_s"]
    return {
        "env_steps_per_s": s["env_steps_per_s"],
        "updates_per_s": s["updates_per_s"],
        "loop_steps_per_s": s["steps_per_s"],
        "env_steps": s["env_steps"],
        "updates": s["train_steps"],
        "wall_time_s": s["wall_time_s"],
        "cpu_time_s": s["cpu_time_s"],
        "timing_s": t,
        "method": cfg.method,
        "train_freq": getattr(cfg.agent, "train_freq", 1),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000, help="control steps to train")
    ap.add_argument("--config", default=str(configs_dir() / "d3dwa.yaml"))
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    result = run(args.steps, args.config)
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{result['env_steps']} env steps, {result['updates']} updates in "
            f"{result['wall_time_s']:.1f} s: env {result['env_steps_per_s']:.1f} steps/s, "
            f"learner {result['updates_per_s']:.1f} updates/s, "
            f"loop {result['loop_steps_per_s']:.1f} steps/s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
