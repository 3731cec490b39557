"""The ``d3dwa`` command line.

    d3dwa worlds                          list the shipped worlds
    d3dwa run --world TS1 --method dwa3   one episode (headless; --gui to watch)
    d3dwa eval --out results/             methods x worlds x seeds -> results.csv, table.md, figures

Every failure the user can cause (unknown name, malformed file, bad checkpoint) ends with a
one-line ``d3dwa: error: ...`` on stderr and exit status 2, not a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from .errors import ConfigError, D3DWAError

TABLE1_WORLDS = ("TS1", "TS2", "TS3", "TS4", "US1", "H1", "H2", "H3")
TABLE2_WORLDS = ("R1", "R2", "R3")


def parse_floats(text: str, n: int, what: str) -> tuple[float, ...]:
    """'1.0,2.5' -> (1.0, 2.5), with a clear error naming the option."""
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError as err:
        raise ConfigError(f"{what} must be {n} comma-separated numbers, got {text!r}") from err
    if len(vals) != n:
        raise ConfigError(f"{what} must be {n} comma-separated numbers, got {text!r}")
    return vals


def split_list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def load_task_world(args: argparse.Namespace):
    """The world of --world with --start/--goal/--time-limit applied."""
    from .world import load_world

    world = load_world(args.world)
    start = parse_floats(args.start, 3, "--start X,Y,YAW") if args.start else None
    goal = parse_floats(args.goal, 2, "--goal X,Y") if args.goal else None
    if start or goal or args.time_limit:
        world = world.with_task(start=start, goal=goal, time_limit=args.time_limit)
    return world


def episode_config(args: argparse.Namespace):
    """EpisodeConfig from --physics-hz / --control-hz (checked: physics must divide evenly)."""
    from .episode import EpisodeConfig
    from .params import PlannerParams, SimParams

    sim = SimParams(physics_hz=args.physics_hz, control_hz=args.control_hz)
    return EpisodeConfig(sim=sim, planner=PlannerParams(control_period=sim.control_period))


def cmd_worlds(args: argparse.Namespace) -> int:
    from .world import list_worlds

    worlds = list_worlds()
    if args.json:
        print(json.dumps([{"name": w.name, "group": w.group, "description": w.description,
                           "goal": list(w.goal), "obstacles": len(w.obstacles)} for w in worlds]))  # fmt: skip
        return 0
    width = max(len(w.name) for w in worlds)
    for w in worlds:
        print(
            f"{w.name:<{width}}  {w.group:<7} goal ({w.goal[0]:.2f}, {w.goal[1]:.2f})  {w.description}"
        )
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from .episode import run_episode
    from .evaluation import make_noise
    from .methods import LABELS, make_controller

    config = episode_config(args)
    world = load_task_world(args)
    controller = make_controller(args.method, args.policy)
    result = run_episode(
        world, controller, seed=args.seed, noise=make_noise(args.noise, args.seed),
        noise_name=args.noise, config=config, gui=args.gui,
    )  # fmt: skip
    if args.plot:
        from .plotting import trajectory_figure

        log = result.log
        t = list(log["t"]) + [result.time_s]
        tau = list(log["tau"]) + list(log["tau"][-1:])
        trajectory_figure(
            world,
            [
                {
                    "label": LABELS.get(args.method, args.method),
                    "method": args.method,
                    "outcome": result.outcome,
                    "t": t,
                    "x": log["true_x"],
                    "y": log["true_y"],
                    "tau": tau,
                }
            ],  # fmt: skip
            args.plot,
            colour_by=args.colour_by,
        )
    summary = result.summary()
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"{summary['world']} {summary['method']} seed {summary['seed']}: {summary['outcome']} "
            f"in {summary['time_s']:.1f} s, TL {summary['tl_m']:.2f} m, PD {summary['pd_rad']:.2f} rad, "
            f"min clearance {summary['min_clearance_m']:.3f} m ({summary['steps']} steps)"
        )
        if args.plot:
            print(f"figure: {args.plot}")
    return 0


def default_methods() -> list[str]:
    """Fixed baselines plus every learned method whose shipped policy exists."""
    from .methods import FIXED, LEARNED, default_policy_path

    return list(FIXED) + [m for m in LEARNED if default_policy_path(m).exists()]


def cmd_eval(args: argparse.Namespace) -> int:
    from .evaluation import Job, evaluate, world_figures
    from .methods import check_method
    from .table import paper_table, success_table
    from .world import load_world

    config = episode_config(args)
    methods = [
        check_method(m) for m in (split_list(args.methods) if args.methods else default_methods())
    ]
    worlds = [load_world(w) for w in (split_list(args.worlds) if args.worlds else TABLE1_WORLDS)]
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be >= 1, got {args.seeds}")
    seeds = list(range(args.seed, args.seed + args.seeds))
    for m in methods:  # fail fast on a missing policy, before any episode runs
        from .methods import make_controller

        make_controller(m, args.policy if len(methods) == 1 else None)
    jobs = [
        Job(w, m, s, args.noise, args.policy if len(methods) == 1 else None)
        for w in worlds for m in methods for s in seeds
    ]  # fmt: skip
    out = Path(args.out)
    workers = args.workers or os.cpu_count() or 1
    rows = evaluate(jobs, out, workers=workers, config=config, progress=not args.json)
    names = [w.name for w in worlds]
    table = (
        f"# Evaluation: {', '.join(names)}\n\nNoise profile: `{args.noise}`; seeds: {seeds[0]}..{seeds[-1]}.\n\n"
        "Time [s], TL [m], PD [rad] averaged over successful seeds; T = timeout, C = collision; "
        "best per world and metric in bold.\n\n"
        + paper_table(rows, methods, names)
        + "\n## Success rate and time (mean ± std over seeds)\n\n"
        + success_table(rows, methods, names)
    )
    tmp = out / "table.md.tmp"
    tmp.write_text(table)
    os.replace(tmp, out / "table.md")
    figures = world_figures(out, worlds, methods, seeds[0], args.noise)
    if args.json:
        print(json.dumps(rows))
    else:
        print(table)
        print(f"results: {out / 'results.csv'}\ntable:   {out / 'table.md'}")
        print(f"figures: {len(figures)} in {out / 'figures'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="d3dwa", description="D3DWA testbed: Kachaka + DWA + D3QN in PyBullet"
    )
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("worlds", help="list the shipped worlds")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_worlds)

    def add_common(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--noise",
            default="none",
            help="randomisation profile: none, paper, real, harsh, or a YAML path",
        )
        p.add_argument(
            "--policy",
            help="checkpoint directory for a learned method (default: policies/<method>)",
        )
        p.add_argument("--json", action="store_true", help="print JSON instead of text")
        p.add_argument(
            "--physics-hz", type=int, default=240, help="physics rate (multiple of --control-hz)"
        )
        p.add_argument("--control-hz", type=int, default=10, help="control (planning) rate")

    p = sub.add_parser("run", help="run one episode")
    p.add_argument("--world", required=True, help="world name (see `d3dwa worlds`) or a world file")
    p.add_argument(
        "--method", required=True, help="dwa1, dwa2, dwa3, dqdwa, d3dwa-weights, d3dwa, d3dwa-dr"
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--start", help="X,Y,YAW start pose (m, m, rad)")
    p.add_argument("--goal", help="X,Y goal (m)")
    p.add_argument("--time-limit", type=float, help="episode time limit, s (default 60)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet GUI")
    p.add_argument("--plot", help="write the trajectory over the map to this PNG")
    p.add_argument(
        "--colour-by", choices=("time", "tau"), default="time", help="trajectory colour in --plot"
    )
    add_common(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("eval", help="evaluate methods on worlds over seeds")
    p.add_argument(
        "--methods",
        help="comma list (default: fixed baselines + learned methods with a shipped policy)",
    )
    p.add_argument("--worlds", help="comma list of names or files (default: TS1..TS4,US1,H1..H3)")
    p.add_argument("--seeds", type=int, default=1, help="number of seeds per (method, world)")
    p.add_argument("--seed", type=int, default=0, help="first seed")
    p.add_argument("--out", default="results", help="results directory (resumes if it exists)")
    p.add_argument("--workers", type=int, default=0, help="processes (default: all cores)")
    add_common(p)
    p.set_defaults(func=cmd_eval)

    from transfer.cli_commands import (
        add_compare_arguments,
        add_record_arguments,
        add_replay_arguments,
    )

    p = sub.add_parser(
        "replay", help="replay a ROS bag through the observation pipeline and a method"
    )
    add_replay_arguments(p)
    p.set_defaults(func=cmd_replay)
    p = sub.add_parser("record", help="record a simulated episode as a ROS 2 bag")
    add_record_arguments(p)
    p.set_defaults(func=cmd_record)
    p = sub.add_parser("compare-scans", help="per-sector scan statistics of two bags")
    add_compare_arguments(p)
    p.set_defaults(func=cmd_compare)
    return ap


def cmd_replay(args: argparse.Namespace) -> int:
    from transfer.cli_commands import run_replay

    from .transfer_bridge import make_step_fn

    return run_replay(args, make_step_fn=make_step_fn)


def cmd_record(args: argparse.Namespace) -> int:
    from transfer.cli_commands import run_record

    from .transfer_bridge import record_episode

    return run_record(args, record_episode)


def cmd_compare(args: argparse.Namespace) -> int:
    from transfer.cli_commands import run_compare

    return run_compare(args)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except D3DWAError as err:
        print(f"d3dwa: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("d3dwa: interrupted; finished episodes are kept in results.csv", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
