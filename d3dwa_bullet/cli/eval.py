"""``d3dwa eval``: methods x worlds x seeds -> results.csv, table.md and trajectory figures."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from d3dwa_bullet.cli.options import (
    add_backend_options,
    add_episode_options,
    default_methods,
    episode_config,
    split_list,
    workers_arg,
)
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.world.registry import load_world, world_names

TABLE1_GROUPS = ("train", "unseen")
"""World groups of Table I (TS1..TS4, US1, H1..H3): the default worlds of ``d3dwa eval``."""
TABLE2_GROUPS = ("real",)
"""World groups of Table II (R1..R3)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="evaluate methods on worlds over seeds")
    p.add_argument(
        "--methods",
        help="comma list (default: fixed baselines + learned methods with a shipped policy)",
    )
    p.add_argument("--worlds", help="comma list of names or files (default: TS1..TS4,US1,H1..H3)")
    p.add_argument("--seeds", type=int, default=1, help="number of seeds per (method, world)")
    p.add_argument("--seed", type=int, default=0, help="first seed")
    p.add_argument("--out", default="results", help="results directory (resumes if it exists)")
    add_backend_options(p)
    add_episode_options(p)
    p.set_defaults(func=cmd_eval)


def cmd_eval(args: argparse.Namespace) -> int:
    # start-up cost: the evaluation imports the simulator (pybullet) and the planner (numba)
    from d3dwa_bullet.evaluation.backends import check_address
    from d3dwa_bullet.evaluation.jobs import Job, evaluate, world_figures
    from d3dwa_bullet.evaluation.report import eval_markdown
    from d3dwa_bullet.methods import check_method, make_controller

    check_address(args.ray)
    config = episode_config(args)
    methods = [
        check_method(m) for m in (split_list(args.methods) if args.methods else default_methods())
    ]
    world_args = split_list(args.worlds) if args.worlds else list(world_names(*TABLE1_GROUPS))
    worlds = [load_world(w) for w in world_args]
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be >= 1, got {args.seeds}")
    seeds = list(range(args.seed, args.seed + args.seeds))
    for m in methods:  # fail fast on a missing policy, before any episode runs
        make_controller(m, args.policy if len(methods) == 1 else None)
    jobs = [
        Job(w, m, s, args.noise, args.policy if len(methods) == 1 else None)
        for w in worlds for m in methods for s in seeds
    ]  # fmt: skip
    out = Path(args.out)
    names = [w.name for w in worlds]
    settings = {
        "kind": "eval", "command": getattr(args, "command_line", ""), "methods": methods,
        "worlds": names, "world_sources": [str(Path(a).resolve()) if Path(a).suffix else a
                                           for a in world_args],
        "seeds": seeds, "noise": args.noise,
    }  # fmt: skip
    rows = evaluate(
        jobs, out, workers=workers_arg(args), config=config, progress=not args.json,
        ray_address=args.ray, settings=settings,
    )  # fmt: skip
    table = eval_markdown(rows, methods, names, seeds, args.noise)
    atomic_write_text(out / "table.md", table)
    figures = world_figures(out, worlds, methods, seeds[0], args.noise)
    if args.json:
        print(json.dumps(rows))
    else:
        print(table)
        print(f"results: {out / 'results.csv'}\ntable:   {out / 'table.md'}")
        print(f"figures: {len(figures)} in {out / 'figures'}")
    return 0
