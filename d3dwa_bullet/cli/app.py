"""The ``d3dwa`` command line.

    d3dwa worlds                          list the shipped worlds
    d3dwa run --world TS1 --method dwa3   one episode (headless; --gui to watch)
    d3dwa eval --out results/             methods x worlds x seeds -> results.csv, table.md, figures
    d3dwa sweep --methods dwa1 --out DIR  methods x noise levels on R1-R3 + unseen layouts -> plots
    d3dwa report DIR                      a results directory -> DIR/report.md
    d3dwa train --config configs/d3dwa.yaml --out runs/d3dwa   train a learned method (--resume)

Every failure the user can cause (unknown name, malformed file, bad checkpoint) ends with a
one-line ``d3dwa: error: ...`` on stderr and exit status 2, not a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path

from d3dwa_bullet.errors import ConfigError, D3DWAError

TABLE1_WORLDS = ("TS1", "TS2", "TS3", "TS4", "US1", "H1", "H2", "H3")
TABLE2_WORLDS = ("R1", "R2", "R3")
RAY_HELP = (
    "run episodes on Ray: 'local' (a private instance), 'auto' (the cluster of `ray start`), "
    "or HOST:PORT / ray://HOST:PORT"
)


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
    from d3dwa_bullet.world.model import load_world

    world = load_world(args.world)
    start = parse_floats(args.start, 3, "--start X,Y,YAW") if args.start else None
    goal = parse_floats(args.goal, 2, "--goal X,Y") if args.goal else None
    if start or goal or args.time_limit:
        world = world.with_task(start=start, goal=goal, time_limit=args.time_limit)
    return world


def episode_config(args: argparse.Namespace):
    """EpisodeConfig from --physics-hz / --control-hz (checked: physics must divide evenly)."""
    from d3dwa_bullet.episode import EpisodeConfig
    from d3dwa_bullet.params import PlannerParams, SimParams

    sim = SimParams(physics_hz=args.physics_hz, control_hz=args.control_hz)
    return EpisodeConfig(sim=sim, planner=PlannerParams(control_period=sim.control_period))


def cmd_worlds(args: argparse.Namespace) -> int:
    from d3dwa_bullet.world.model import list_worlds

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
    from d3dwa_bullet.episode import run_episode
    from d3dwa_bullet.evaluation.jobs import make_noise
    from d3dwa_bullet.methods import LABELS, make_controller

    config = episode_config(args)
    world = load_task_world(args)
    controller = make_controller(args.method, args.policy)
    result = run_episode(
        world, controller, seed=args.seed, noise=make_noise(args.noise, args.seed),
        noise_name=args.noise, config=config, gui=args.gui,
    )  # fmt: skip
    if args.plot:
        from d3dwa_bullet.evaluation.plotting import trajectory_figure

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
    from d3dwa_bullet.methods import FIXED, LEARNED, default_policy_path

    return list(FIXED) + [m for m in LEARNED if default_policy_path(m).exists()]


def cmd_eval(args: argparse.Namespace) -> int:
    from d3dwa_bullet.evaluation.backends import check_address
    from d3dwa_bullet.evaluation.jobs import Job, evaluate, world_figures, write_text_atomic
    from d3dwa_bullet.evaluation.report import eval_markdown
    from d3dwa_bullet.methods import check_method
    from d3dwa_bullet.world.model import load_world

    check_address(args.ray)
    config = episode_config(args)
    methods = [
        check_method(m) for m in (split_list(args.methods) if args.methods else default_methods())
    ]
    world_args = split_list(args.worlds) if args.worlds else list(TABLE1_WORLDS)
    worlds = [load_world(w) for w in world_args]
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be >= 1, got {args.seeds}")
    seeds = list(range(args.seed, args.seed + args.seeds))
    for m in methods:  # fail fast on a missing policy, before any episode runs
        from d3dwa_bullet.methods import make_controller

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
    write_text_atomic(out / "table.md", table)
    figures = world_figures(out, worlds, methods, seeds[0], args.noise)
    if args.json:
        print(json.dumps(rows))
    else:
        print(table)
        print(f"results: {out / 'results.csv'}\ntable:   {out / 'table.md'}")
        print(f"figures: {len(figures)} in {out / 'figures'}")
    return 0


def workers_arg(args: argparse.Namespace) -> int:
    """--workers, default all cores; refuses negative counts."""
    if args.workers < 0:
        raise ConfigError(f"--workers must be >= 0 (0 = all cores), got {args.workers}")
    return args.workers or os.cpu_count() or 1


def cmd_sweep(args: argparse.Namespace) -> int:
    from d3dwa_bullet.evaluation.backends import check_address
    from d3dwa_bullet.evaluation.sweep import (
        AXES,
        PROFILES,
        SHIPPED_WORLDS,
        STYLES,
        SweepSettings,
        run_sweep,
        summary_records,
    )

    check_address(args.ray)
    settings = SweepSettings(
        methods=tuple(split_list(args.methods) if args.methods else default_methods()),
        worlds=tuple(split_list(args.worlds) if args.worlds is not None else SHIPPED_WORLDS),
        styles=tuple(split_list(args.styles) if args.styles is not None else STYLES),
        layouts=args.layouts, seeds=args.seeds, first_seed=args.seed, levels=args.levels,
        axes=tuple(split_list(args.axes) if args.axes is not None else AXES),
        profiles=tuple(split_list(args.profiles) if args.profiles is not None else PROFILES),
        time_limit=args.time_limit,
    )  # fmt: skip
    if args.time_limit is not None and args.time_limit <= 0:
        raise ConfigError(f"--time-limit must be > 0 s, got {args.time_limit}")
    out = Path(args.out)
    rows, complete = run_sweep(
        settings, out, workers=workers_arg(args), ray_address=args.ray,
        config=episode_config(args), progress=not args.json,
        policy=args.policy if len(settings.methods) == 1 else None,
        command=getattr(args, "command_line", ""),
    )  # fmt: skip
    if args.json:
        print(json.dumps({"complete": complete, "episodes": len(rows),
                          "summary": summary_records(rows, settings)}))  # fmt: skip
    else:
        print(f"{len(rows)} episodes in {out / 'results.csv'}")
        if complete:
            print(f"tables:  {out / 'sweep.md'}\nfigures: {out / 'figures'}/sweep_*.png")
            print(f"page:    d3dwa report {out}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from d3dwa_bullet.evaluation.report import write_report
    from d3dwa_bullet.resources import policies_dir

    report = write_report(args.dir, args.policies or policies_dir())
    if args.json:
        print(json.dumps({"report": str(report.path), "kind": report.kind,
                          "complete": report.complete, "done": report.done,
                          "expected": report.expected}))  # fmt: skip
    else:
        print(f"report: {report.path}")
    if not report.complete:
        print(
            f"d3dwa: warning: {args.dir} is incomplete ({report.done} of {report.expected} "
            "episodes); the page says so",
            file=sys.stderr,
        )
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
    p.add_argument("--ray", metavar="ADDRESS", help=RAY_HELP)
    add_common(p)
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser(
        "sweep", help="success and time vs noise level on R1-R3 and unseen generated layouts"
    )
    p.add_argument("--methods", help="comma list (default: fixed baselines + shipped policies)")
    p.add_argument("--out", required=True, help="results directory (resumes if it exists)")
    p.add_argument("--levels", type=int, default=4, help="non-zero levels per noise axis")
    p.add_argument(
        "--layouts", type=int, default=2, help="unseen generated layouts per R1/R2/R3 style"
    )
    p.add_argument("--seeds", type=int, default=2, help="episode seeds per condition")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--worlds", help="shipped worlds, comma list (default: R1,R2,R3; '' for none)")
    p.add_argument("--styles", help="generator styles (default: R1-style,R2-style,R3-style)")
    p.add_argument(
        "--axes", help="noise axes (default: lidar_dropout,lidar_range,slip,odometry; '' for none)"
    )
    p.add_argument("--profiles", help="profiles (default: none,paper,real,harsh; '' for none)")
    p.add_argument("--time-limit", type=float, help="episode time limit override, s")
    p.add_argument("--workers", type=int, default=0, help="processes (default: all cores)")
    p.add_argument("--ray", metavar="ADDRESS", help=RAY_HELP)
    p.add_argument("--policy", help="checkpoint directory (only with a single --methods)")
    p.add_argument("--json", action="store_true", help="print summary statistics as JSON")
    p.add_argument("--physics-hz", type=int, default=240, help="physics rate")
    p.add_argument("--control-hz", type=int, default=10, help="control (planning) rate")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("report", help="one Markdown page (tables + figures) for a results dir")
    p.add_argument("dir", help="a results directory written by `d3dwa eval` or `d3dwa sweep`")
    p.add_argument("--policies", help="where learning curves live (default: policies/)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("train", help="train a learned method (D3QN or tabular DQDWA)")
    add_train_arguments(p)
    p.set_defaults(func=cmd_train)

    from d3dwa_bullet.cli.transfer import (
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


def add_train_arguments(p: argparse.ArgumentParser) -> None:
    """Options of `d3dwa train` (also used by scripts/train_randomized.py)."""
    p.add_argument(
        "--method", help="d3dwa, d3dwa-weights, d3dwa-dr or dqdwa (default: the config's)"
    )
    p.add_argument(
        "--config",
        help="training config YAML (default: configs/<method>.yaml of the repository)",
    )
    p.add_argument("--out", help="run directory (default: runs/<method>__s<seed>__<time>)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out exactly")
    p.add_argument(
        "--total-steps", type=int, help="override total_steps (may extend a run on --resume)"
    )
    p.add_argument("--seed", type=int, help="override the config's seed")
    p.add_argument(
        "--export", help="also copy the run's policy here when done (e.g. policies/d3dwa)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def cmd_train(args: argparse.Namespace) -> int:
    import time

    from d3dwa_bullet.learning.training.trainer import (
        TrainConfig,
        export_policy,
        load_train_config,
        train,
    )
    from d3dwa_bullet.resources import configs_dir

    overrides = {"method": args.method, "total_steps": args.total_steps, "seed": args.seed}
    if args.resume and not args.out:
        raise ConfigError("--resume needs --out DIR (the run to continue)")
    if args.config:
        config: TrainConfig | None = load_train_config(args.config, **overrides)
    elif args.resume:  # the run's own config; only total_steps may be extended
        saved = Path(args.out) / "config.json"
        config = load_train_config(saved, **overrides) if saved.exists() else None
    elif args.method and (configs_dir() / f"{args.method}.yaml").exists():
        config = load_train_config(configs_dir() / f"{args.method}.yaml", **overrides)
    else:
        config = TrainConfig(**{k: v for k, v in overrides.items() if v is not None})
    if args.out:
        out = Path(args.out)
    else:
        assert config is not None
        out = Path("runs") / f"{config.method}__s{config.seed}__{time.strftime('%Y%m%d-%H%M%S')}"
    try:
        summary = train(
            config, out, resume=args.resume, progress=not (args.no_progress or args.json)
        )
    except KeyboardInterrupt:  # a second Ctrl-C: stopped without saving
        print(
            f"d3dwa: training aborted; the last checkpoint ({out / 'checkpoints' / 'latest'}) "
            "is intact: resume with --resume",
            file=sys.stderr,
        )
        return 130
    if summary["status"] == "done" and args.export:
        keep = load_train_config(out / "config.json").keep
        summary["exported"] = str(export_policy(out, args.export, keep))
    if args.json:
        print(json.dumps(summary))
        return 130 if summary["status"] == "interrupted" else 0
    best = summary["best_eval"]
    print(
        f"{summary['method']}: {summary['status']} after {summary['env_steps']} env steps, "
        f"{summary['train_steps']} updates, {summary['episodes']} episodes in "
        f"{summary['wall_time_s']:.0f} s ({summary['steps_per_s']} steps/s)"
    )
    if best:
        print(
            f"best greedy evaluation (training worlds) at step {best['step']}: success "
            f"{best['success_rate']:.2f}, collisions {best['collision_rate']:.2f}"
        )
    if summary["status"] == "interrupted":
        print(f"checkpoint saved; continue with: d3dwa train --resume --out {out}")
        return 130
    print(f"run: {out}\npolicy: {summary['policy']}")
    if "exported" in summary:
        print(f"exported: {summary['exported']}")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from d3dwa_bullet.cli.transfer import run_replay
    from transfer.sim_bridge import make_step_fn

    return run_replay(args, make_step_fn=make_step_fn)


def cmd_record(args: argparse.Namespace) -> int:
    from d3dwa_bullet.cli.transfer import run_record
    from transfer.sim_bridge import record_episode

    return run_record(args, record_episode)


def cmd_compare(args: argparse.Namespace) -> int:
    from d3dwa_bullet.cli.transfer import run_compare

    return run_compare(args)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    args.command_line = shlex.join(["d3dwa", *(sys.argv[1:] if argv is None else argv)])
    previous = signal.getsignal(signal.SIGTERM)
    if threading.current_thread() is threading.main_thread():
        # `kill PID` stops like Ctrl-C: finished rows are kept, local workers terminated.
        signal.signal(signal.SIGTERM, _sigterm)
    try:
        return int(args.func(args) or 0)
    except D3DWAError as err:
        print(f"d3dwa: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("d3dwa: interrupted; finished episodes are kept in results.csv", file=sys.stderr)
        return 130
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)


def _sigterm(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
