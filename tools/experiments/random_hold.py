"""The `random` reference at a decision period: does a policy beat chance at its own rate?

    python -m tools.experiments.random_hold --hold 10 --seeds 0,1,2
    python -m tools.experiments.random_hold --hold 10 --seeds 0,1,2 --recovery nav2

A uniform chooser over the 100 (weights, tau) actions (the `random` method's controller, its
own stream of the episode seed) that keeps each draw for ``--hold`` control steps, run once
per episode seed on R1-R3 and the sweep's 30 unseen generated layouts (generator seeds
2^31 .. 2^31 + 9 per style, as ``d3dwa sweep --layouts 10``), no noise. Prints the goals per
episode seed (``--json``: one object). A policy trained with ``decision_steps: k`` is to be
read against ``--hold k``: holding any action for 1 s is worth something by itself.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace

from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.methods import REFERENCE, Controller
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE, generate_world
from d3dwa_bullet.world.registry import load_world

STYLES = ("R1-style", "R2-style", "R3-style")


def layouts() -> list:
    shipped = [load_world(n) for n in ("R1", "R2", "R3")]
    generated = [generate_world(s, UNSEEN_LAYOUT_SEED_BASE + i) for s in STYLES for i in range(10)]
    return shipped + generated


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.experiments.random_hold")
    ap.add_argument("--hold", type=int, default=1, help="control steps each draw is kept")
    ap.add_argument("--seeds", default="0", help="episode seeds, e.g. 0,1,2")
    ap.add_argument(
        "--recovery",
        default="none",
        help="none (the paper's stack) or nav2 (docs/design.md#recovery)",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        print(f"random_hold: error: --seeds {args.seeds!r}: expected e.g. 0,1,2", file=sys.stderr)
        return 2
    if not 1 <= args.hold <= 100 or min(seeds) < 0:
        print("random_hold: error: --hold must be in [1, 100] and seeds >= 0", file=sys.stderr)
        return 2
    try:
        config = replace(EpisodeConfig(), recovery=recovery_params(args.recovery))
    except ConfigError as err:
        print(f"random_hold: error: --recovery: {err}", file=sys.stderr)
        return 2
    worlds = layouts()
    goals = {}
    for seed in seeds:
        n = 0
        for world in worlds:
            controller = Controller(
                "random", actions=REFERENCE["random"], uniform=True, hold=args.hold
            )
            n += run_episode(world, controller, seed, config=config).outcome == "goal"
        goals[seed] = n
        if not args.json:
            print(
                f"hold {args.hold}, recovery {args.recovery}, episode seed {seed}: "
                f"{n}/{len(worlds)} goals",
                flush=True,
            )
    total = sum(goals.values())
    rate = total / (len(worlds) * len(seeds))
    if args.json:
        print(
            json.dumps(
                {
                    "hold": args.hold,
                    "recovery": args.recovery,
                    "layouts": len(worlds),
                    "goals": goals,
                    "success": rate,
                }
            )
        )
    else:
        print(f"hold {args.hold}: {total}/{len(worlds) * len(seeds)} goals ({rate:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
