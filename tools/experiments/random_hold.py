"""The `random` reference at a decision period, on the 33 layouts: a thin caller of the registry.

The held reference is a method of the registry (``random@k``, ``random-weights@k``:
docs/design/methods.md#floors), in the default tables of ``d3dwa eval`` and ``d3dwa sweep``; this tool
only runs it on R1-R3 and the 30 unseen generated layouts and counts goals per seed.

    python -m tools.experiments.random_hold --hold 10 --seeds 0,1,2
    python -m tools.experiments.random_hold --hold 10 --seeds 0,1,2 --recovery nav2
    python -m tools.experiments.random_hold --hold 10 --reference random-weights --noise real

A uniform chooser over a reference method's actions (``--reference``: `random`, the 100
(weights, tau) actions, by default; `random-weights`, the 25 weight actions), its own stream
of the episode seed, that keeps each draw for ``--hold`` control steps, run once per episode
seed on R1-R3 and the sweep's 30 unseen generated layouts (generator seeds 2^31 .. 2^31 + 9
per style, as ``d3dwa sweep --layouts 10``), under a named noise profile (``--noise``, none by
default; each episode's noise drawn from its seed, as ``d3dwa sweep`` does). Prints the goals
per episode seed (``--json``: one object). A policy trained with ``decision_steps: k`` is to be
read against ``--hold k``: holding any action for 1 s is worth something by itself.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.method_specs import HOLD_MARK, REFERENCE, check_method
from d3dwa_bullet.params import recovery_params
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE, generate_world
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, fail, tool_main

STYLES = ("R1-style", "R2-style", "R3-style")


def layouts() -> list:
    shipped = [load_world(n) for n in ("R1", "R2", "R3")]
    generated = [generate_world(s, UNSEEN_LAYOUT_SEED_BASE + i) for s in STYLES for i in range(10)]
    return shipped + generated


@tool_main
def main(argv: list[str] | None = None) -> int:
    ap = ToolParser(prog="python -m tools.experiments.random_hold")
    ap.add_argument("--hold", default="1", help="control steps each draw is kept")
    ap.add_argument("--seeds", default="0", help="episode seeds, e.g. 0,1,2")
    ap.add_argument(
        "--recovery",
        default="none",
        help="none (the paper's stack) or nav2 (docs/design/recovery.md#recovery)",
    )
    ap.add_argument("--reference", default="random", help=f"one of {', '.join(REFERENCE)}")
    ap.add_argument(
        "--noise", default="none", help="a named noise profile: none, paper, real, harsh"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        print(f"random_hold: error: --seeds {args.seeds!r}: expected e.g. 0,1,2", file=sys.stderr)
        return 2
    if min(seeds) < 0:
        print("random_hold: error: --seeds must be >= 0", file=sys.stderr)
        return 2
    try:
        config = replace(EpisodeConfig(), recovery=recovery_params(args.recovery))
    except ConfigError as err:
        fail("random_hold", f"--recovery: {err}")
    if args.reference not in REFERENCE:
        print(
            f"random_hold: error: --reference {args.reference!r}: choose one of "
            f"{', '.join(REFERENCE)}",
            file=sys.stderr,
        )
        return 2
    method = f"{args.reference}{HOLD_MARK}{args.hold}"
    try:
        check_method(method)  # the registry judges the decision period (0, -1, 1.5, 101, ...)
    except D3DWAError as err:
        fail("random_hold", f"--hold {args.hold}: {err}")
    hold = int(args.hold)
    try:
        make_noise(args.noise, 0)
    except D3DWAError as err:
        fail("random_hold", f"--noise {args.noise!r}: {err}")
    worlds = layouts()
    goals = {}
    for seed in seeds:
        n = 0
        for world in worlds:
            controller = make_controller(method)
            noise = make_noise(args.noise, seed)
            episode = run_episode(
                world, controller, seed, noise=noise, noise_name=args.noise, config=config
            )
            n += episode.outcome == "goal"
        goals[seed] = n
        if not args.json:
            print(
                f"{args.reference}, hold {hold}, noise {args.noise}, recovery "
                f"{args.recovery}, episode seed {seed}: "
                f"{n}/{len(worlds)} goals",
                flush=True,
            )
    total = sum(goals.values())
    rate = total / (len(worlds) * len(seeds))
    if args.json:
        print(
            json.dumps(
                {
                    "reference": args.reference,
                    "hold": hold,
                    "noise": args.noise,
                    "recovery": args.recovery,
                    "layouts": len(worlds),
                    "goals": goals,
                    "success": rate,
                }
            )
        )
    else:
        print(f"hold {hold}: {total}/{len(worlds) * len(seeds)} goals ({rate:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
