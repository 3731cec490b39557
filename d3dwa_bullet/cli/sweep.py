"""``d3dwa sweep``: methods x noise levels on R1-R3 and unseen generated layouts -> plots.

``--out DIR`` is checked before any episode runs; an existing sweep directory is resumed or
extended, never shrunk or mixed, as with ``d3dwa eval`` (see
:func:`d3dwa_bullet.evaluation.same_run.check_same_run`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from d3dwa_bullet.backends import check_address
from d3dwa_bullet.cli.options import (
    ALLOW_EMPTY_HELP,
    add_backend_options,
    add_policy_root_option,
    add_recovery_options,
    add_reuse_options,
    add_sim_backend_option,
    default_methods,
    episode_config,
    list_arg,
    load_cli_world,
    policy_arg,
    seed_arg,
    split_list,
    time_limit_arg,
    workers_arg,
)
from d3dwa_bullet.cli.output import check_out_dir, json_text
from d3dwa_bullet.cli.plan_options import add_global_plan_option
from d3dwa_bullet.cli.suites import add_suite_options, suite_world_names
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.noise_axes import AXES
from d3dwa_bullet.evaluation.plans.plan_file import Plan, check_fits, load_plan
from d3dwa_bullet.evaluation.plans.plan_seeds import with_plan_seeds
from d3dwa_bullet.evaluation.plans.setting_sides import check_setting_options, setting_dirs
from d3dwa_bullet.evaluation.policy_runs import check_policy_root
from d3dwa_bullet.evaluation.results import read_meta
from d3dwa_bullet.evaluation.reuse import reuse_arg, reused_lines
from d3dwa_bullet.evaluation.sweep_settings import (
    PROFILES,
    SHIPPED_WORLDS,
    STYLES,
    SweepSettings,
)
from d3dwa_bullet.external.resolve import with_floors
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep", help="success and time vs noise level on R1-R3 and unseen generated layouts"
    )
    p.add_argument(
        "--methods", help="comma list (default: fixed baselines, random, shipped policies)"
    )
    p.add_argument(
        "--out",
        required=True,
        help="results directory; an existing sweep is resumed or extended (same settings)",
    )
    p.add_argument("--levels", type=int, default=4, help="non-zero levels per noise axis")
    p.add_argument(
        "--layouts", type=int, default=2, help="unseen generated layouts per R1/R2/R3 style"
    )
    p.add_argument(
        "--layout-seed",
        type=int,
        metavar="S",
        help="the first unseen layout's generator seed per style (default 2^31; the layouts are "
        "S, S+1, ...); seeds below 2^31 are training's",
    )
    p.add_argument("--seeds", type=int, default=2, help="episode seeds per condition")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--worlds", help="shipped worlds, comma list (default: R1,R2,R3; '' for none)")
    add_suite_options(p)
    p.add_argument("--allow-empty", action="store_true", help=ALLOW_EMPTY_HELP)
    p.add_argument(
        "--styles", help="generator styles (default: R1-style,R2-style,R3-style; none with --suite)"
    )
    p.add_argument(
        "--axes", help="noise axes (default: lidar_dropout,lidar_range,slip,odometry; '' for none)"
    )
    p.add_argument("--profiles", help="profiles (default: none,paper,real,harsh; '' for none)")
    p.add_argument("--time-limit", type=float, help="episode time limit override, s")
    add_backend_options(p)
    p.add_argument("--policy", help="checkpoint directory (only with a single --methods)")
    add_policy_root_option(p)
    p.add_argument(
        "--policy-seeds",
        default="all",
        help="training seeds of each learned method: 'all' (default), a list like 0,2, or per method "
        "like 'd3dwa=0-4;d3dwa-dr=0,1' (a --plan with seeds: sets them)",
    )
    p.add_argument(
        "--plan",
        help="a sequential plan file: run it look by look (docs/design/sequential-plans.md)",
    )
    p.add_argument("--json", action="store_true", help="print summary statistics as JSON")
    p.add_argument("--physics-hz", type=int, default=240, help="physics rate")
    p.add_argument("--control-hz", type=int, default=10, help="control (planning) rate")
    add_recovery_options(p)
    add_sim_backend_option(p)
    add_global_plan_option(p)
    add_reuse_options(p)
    p.set_defaults(func=cmd_sweep, interrupted="finished episodes are kept in results.csv")


def cmd_sweep(args: argparse.Namespace) -> int:
    # Settings, counts, worlds and profiles are checked before the simulator is imported, so a
    # refusal comes at once (evaluation.sweep_settings is pure).
    check_address(args.ray)
    workers = workers_arg(args)
    seed_arg(args.seed)
    # --suite replaces --worlds, and the generated layouts are left out unless --styles asks
    suite = suite_world_names(args)
    given = split_list(args.worlds) if args.worlds is not None else SHIPPED_WORLDS
    styles = split_list(args.styles) if args.styles is not None else (() if suite else STYLES)
    layout_seed = UNSEEN_LAYOUT_SEED_BASE if args.layout_seed is None else args.layout_seed
    if args.layout_seed is not None and not (styles and args.layouts):  # it would change nothing
        raise ConfigError(
            f"--layout-seed {args.layout_seed}: this sweep generates no layouts (--styles and "
            "--layouts choose them)"
        )
    # a chooser from outside the package gets its floors, as in eval
    listed = list_arg(args.methods, "--methods", lambda: default_methods(args.policy_root))
    methods = tuple(with_floors(listed))
    policy = policy_arg(args.policy, methods)
    root = check_policy_root(args.policy_root, methods, policy)
    settings = SweepSettings(
        methods=methods, worlds=tuple(given if suite is None else suite), styles=tuple(styles),
        layouts=args.layouts, layout_seed=layout_seed, seeds=args.seeds, first_seed=args.seed,
        levels=args.levels,
        axes=tuple(split_list(args.axes) if args.axes is not None else AXES),
        profiles=tuple(split_list(args.profiles) if args.profiles is not None else PROFILES),
        time_limit=time_limit_arg(args.time_limit), policy_seeds=args.policy_seeds,
        policy_root=root,
    )  # fmt: skip
    config = episode_config(args)
    plan = load_plan(args.plan) if args.plan else None
    if plan is not None:
        check_fits(plan, settings.methods, settings.profiles)
        check_setting_options(plan, config.global_plan_name, args.reuse is not None)
        settings = with_plan_seeds(settings, plan, policy)  # each method's seeds, or a refusal
    # a bad or empty world file is refused before any episode
    worlds = [load_cli_world(w, args.allow_empty, warn=False) for w in settings.worlds]
    # start-up cost: the sweep's episodes import the simulator (pybullet) and the planner (numba)
    from d3dwa_bullet.evaluation.jobs import Job, check_distinct
    from d3dwa_bullet.evaluation.sweep import run_sweep, summary_records

    # two different worlds under one name are refused before --out is made
    check_distinct([Job(w, settings.methods[0], 0, "none") for w in worlds])
    reuse = reuse_arg(args.reuse, args.reuse_check, args.out)
    out = check_out_dir(args.out, subdirs=("logs", "figures"))
    for name in setting_dirs(plan, config.global_plan_name).values() if plan is not None else ():
        check_out_dir(out / name, subdirs=("logs", "figures"))  # one sweep directory a setting
    if plan is not None:
        return _run_plan(args, settings, plan, out, workers, config, policy, reuse)
    rows, complete = run_sweep(
        settings, out, workers=workers, ray_address=args.ray,
        config=config, progress=not args.json, policy=policy,
        command=getattr(args, "command_line", ""), reuse=reuse,
    )  # fmt: skip
    if args.json:
        print(json_text({"complete": complete, "episodes": len(rows),
                          "summary": summary_records(rows, settings)}))  # fmt: skip
    else:
        print(f"{len(rows)} episodes in {out / 'results.csv'}")
        for line in reused_lines(read_meta(out).get("settings", {})):
            print(line)
        if complete:
            print(f"tables:  {out / 'sweep.md'}\nfigures: {out / 'figures'}/sweep_*.png")
            print(f"page:    d3dwa report {out}")
    return 0


def _run_plan(args: argparse.Namespace, settings: SweepSettings, plan: Plan, out: Path, workers: int,
              config: Any, policy: str | None, reuse: Any) -> int:  # fmt: skip
    """The sweep under a sequential plan: each cell's last look, then where the log is."""
    from d3dwa_bullet.evaluation.plans.sweep_plan import run_plan_sweep

    records = run_plan_sweep(
        settings, plan, out, workers=workers, ray_address=args.ray, config=config,
        progress=not args.json, policy=policy, command=getattr(args, "command_line", ""), reuse=reuse,
    )  # fmt: skip
    last = {(r["family"], r["a"], r["b"], r["profile"]): r for r in records}
    if args.json:
        print(json_text({"looks": records}))
        return 0
    for (family, a, b, profile), r in last.items():
        print(f"{family}: {a} vs {b} under {profile}: {r['decision']} at look {r['look']} "
              f"({r['layouts']} layouts, A - B {r['difference']:+.4f})")  # fmt: skip
    print(f"looks:   {out / 'looks.md'} ({out / 'looks.jsonl'})")
    for setting, name in setting_dirs(plan, config.global_plan_name).items():
        print(f"episodes with --global-plan {setting}: {out / name}")
    return 0
