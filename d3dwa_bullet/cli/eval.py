"""``d3dwa eval``: methods x worlds x seeds -> results.csv, table.md and trajectory figures.

``--out DIR`` is checked before any episode runs. A directory that already holds an
evaluation is resumed or extended, never shrunk or mixed: the command must list every
(world, method, seed, noise) already in its results.csv (it may add more), with the same
episode settings (rates, world files, policy); otherwise it is refused with a message that
names the mismatch, so table.md and meta.json always describe exactly the rows of results.csv
(see :func:`d3dwa_bullet.evaluation.same_run.check_same_run`). Two different worlds with one
name are refused, naming both files (:func:`d3dwa_bullet.evaluation.jobs.check_distinct`), and
``--out`` is locked while the command writes it: a second eval into it is refused, naming the
first one's pid (:mod:`d3dwa_bullet.dir_lock`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from d3dwa_bullet.backends import check_address
from d3dwa_bullet.cli.options import (
    ALLOW_EMPTY_HELP,
    add_backend_options,
    add_episode_options,
    add_policy_root_option,
    add_reuse_options,
    default_methods,
    episode_config,
    list_arg,
    load_cli_world,
    noise_arg,
    policy_arg,
    seed_arg,
    workers_arg,
)
from d3dwa_bullet.cli.output import check_out_dir, json_text
from d3dwa_bullet.cli.suites import add_suite_options, suite_world_names
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.policy_runs import check_policy_root, method_runs, policy_digests
from d3dwa_bullet.evaluation.results import read_meta
from d3dwa_bullet.evaluation.reuse import reuse_arg, reused_lines
from d3dwa_bullet.external.resolve import method_origins, with_floors
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.limits import MAX_EPISODES, MAX_SEED_VALUE, MAX_SEEDS
from d3dwa_bullet.method_specs import check_method
from d3dwa_bullet.world.registry import world_names

TABLE1_GROUPS = ("train", "unseen")
"""World groups of Table I (TS1..TS4, US1, H1..H3): the default worlds of ``d3dwa eval``."""
TABLE2_GROUPS = ("real",)
"""World groups of Table II (R1..R3)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="evaluate methods on worlds over seeds")
    p.add_argument(
        "--methods",
        help="comma list (default: fixed baselines, random, learned methods with a shipped policy)",
    )
    p.add_argument("--worlds", help="comma list of names or files (default: TS1..TS4,US1,H1..H3)")
    add_suite_options(p)
    add_policy_root_option(p)
    p.add_argument(
        "--seeds", type=int, default=1, help="evaluation seeds per (method, training seed, world)"
    )
    p.add_argument(
        "--policy-seeds",
        help="training seeds of each learned method to evaluate: 'all' (default: every "
        "seed-<k> folder shipped or in --policy), or a list like 0,2 or 0-3",
    )
    p.add_argument("--seed", type=int, default=0, help="first seed")
    p.add_argument("--allow-empty", action="store_true", help=ALLOW_EMPTY_HELP)
    p.add_argument(
        "--out",
        default="results",
        help="results directory; an existing one is resumed or extended: list every method, "
        "world and seed already in it (more may be added), or choose another --out",
    )
    add_backend_options(p)
    add_episode_options(p)
    add_reuse_options(p)
    p.set_defaults(func=cmd_eval, interrupted="finished episodes are kept in results.csv")


def cmd_eval(args: argparse.Namespace) -> int:
    # Counts, names and files are checked before the simulator is imported, so a refusal
    # comes at once (evaluation.policy_runs and methods are pure).
    check_address(args.ray)
    workers = workers_arg(args)
    config = episode_config(args)
    listed = list_arg(args.methods, "--methods", lambda: default_methods(args.policy_root))
    methods = [check_method(m) for m in listed]
    methods = with_floors(methods)  # a chooser from outside the package gets its floors
    suite = suite_world_names(args)
    world_args = suite or list_arg(args.worlds, "--worlds", lambda: world_names(*TABLE1_GROUPS))
    policy = policy_arg(args.policy, methods)
    root = check_policy_root(args.policy_root, methods, policy)
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be >= 1, got {args.seeds}")
    MAX_SEEDS.check("--seeds", args.seeds, "seeds")
    seed_arg(args.seed)
    MAX_SEED_VALUE.check("--seed + --seeds - 1 (the last seed)", args.seed + args.seeds - 1)
    seeds = list(range(args.seed, args.seed + args.seeds))
    runs = method_runs(methods, policy, args.policy_seeds, root)
    MAX_EPISODES.check("eval", len(world_args) * len(runs) * len(seeds), "episodes")
    noise_arg(args.noise)
    loaded = [load_cli_world(w, args.allow_empty) for w in world_args]
    # start-up cost: the episodes import the simulator (pybullet) and the planner (numba)
    from d3dwa_bullet.evaluation.eval_summary import TERMINAL_WORLDS, eval_summary
    from d3dwa_bullet.evaluation.jobs import (
        Job,
        check_distinct,
        evaluate,
        key_apart,
        world_figures,
    )
    from d3dwa_bullet.evaluation.policy_config import policy_config_notes
    from d3dwa_bullet.evaluation.report import eval_markdown, figure_seeds, seeds_markdown
    from d3dwa_bullet.evaluation.training_worlds import (
        SETTINGS_KEY,
        runs_barn_training,
        settings_entry,
    )

    worlds, renamed = key_apart(loaded)
    for run in runs:  # fail fast on a missing policy or profile, before any episode runs
        make_controller(run.method, run.policy)
    jobs = [
        Job(w, r.method, s, args.noise, r.policy, policy_seed=r.policy_seed)
        for w in worlds for r in runs for s in seeds
    ]  # fmt: skip
    check_distinct(jobs)  # before --out is made (evaluate checks again: it has other callers)
    notes = policy_config_notes(runs, config.recovery_name, policy or root)
    training = runs_barn_training(runs)  # read before any episode: a bad record is refused
    reuse = reuse_arg(args.reuse, args.reuse_check, args.out)
    out = check_out_dir(args.out, subdirs=("logs", "figures"))
    names = [w.name for w in worlds]
    settings = {
        "kind": "eval", "command": getattr(args, "command_line", ""), "methods": methods,
        "worlds": names, "world_sources": [str(Path(a).resolve()) if Path(a).suffix else a
                                           for a in world_args],
        "seeds": seeds, "noise": args.noise,
        "policy_seeds": {m: [r.policy_seed for r in runs if r.method == m and
                             r.policy_seed is not None] for m in methods},
        "policy_digests": policy_digests(runs), "method_sources": method_origins(methods),
    }  # fmt: skip
    if policy:
        settings["policy"] = str(Path(policy).resolve())
    if root:
        settings["policy_root"] = root
    settings["policy_notes"] = notes
    settings[SETTINGS_KEY] = settings_entry(training)
    with locked_dir(out):  # one writer: the episodes, then the tables and figures
        rows = evaluate(
            jobs, out, workers=workers, config=config, progress=not args.json,
            ray_address=args.ray, settings=settings, reuse=reuse,
        )  # fmt: skip
        recovery = config.recovery_name
        table = eval_markdown(
            rows, methods, names, seeds, args.noise, recovery=recovery, renamed=renamed,
            policy_notes=notes, scan_filter=config.scan_filter, barn_training=training,
        )  # fmt: skip
        atomic_write_text(out / "table.md", table)
        atomic_write_text(out / "table_seeds.md", seeds_markdown(rows, methods, names, training))
        if not args.json:  # the tables first: the figures take minutes on many worlds
            if len(names) > TERMINAL_WORLDS:  # per-world tables a terminal cannot show: file only
                print(eval_summary(rows, methods, names, seeds, args.noise, recovery, training))
                print(f"per-world tables ({len(names)} worlds): {out / 'table.md'}\n", flush=True)
            else:
                print(table, flush=True)
        figures = world_figures(
            out, worlds, methods, seeds[0], args.noise, figure_seeds(rows), progress=not args.json
        )
    if args.json:
        print(json_text(rows))
    else:
        print(f"results: {out / 'results.csv'}\ntable:   {out / 'table.md'}")
        print(f"seeds:   {out / 'table_seeds.md'} (one row per training seed)")
        print(f"figures: {len(figures)} in {out / 'figures'}")
        for line in reused_lines(read_meta(out).get("settings", {})):
            print(line)
    return 0
