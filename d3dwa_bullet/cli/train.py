"""``d3dwa train``: train a learned method (D3QN or tabular DQDWA), or resume a run."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.limits import MAX_TOTAL_STEPS, check_processes
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.method_specs import LEARNED
from d3dwa_bullet.resources import configs_dir
from d3dwa_bullet.seed_dirs import parse_seeds
from d3dwa_bullet.world.barn import barn_split_ids

#: BARN's train split's size: the bound of --barn-worlds.
BARN_TRAIN_SIZE = len(barn_split_ids("train"))


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train a learned method (D3QN or tabular DQDWA)")
    add_train_arguments(p)
    p.set_defaults(func=cmd_train)


def add_train_arguments(p: argparse.ArgumentParser) -> None:
    """Options of `d3dwa train` (also used by scripts/train_randomized.py)."""
    p.add_argument("--method", help=f"one of {', '.join(LEARNED)} (default: the config's)")
    p.add_argument(
        "--config",
        help="training config YAML (default: the shipped configs/<method>.yaml)",
    )
    p.add_argument("--out", help="run directory (default: runs/<method>__s<seed>__<time>)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out exactly")
    p.add_argument(
        "--total-steps", type=int, help="override total_steps (may extend a run on --resume)"
    )
    p.add_argument("--seed", type=int, help="override the config's seed")
    p.add_argument(
        "--barn-worlds",
        type=int,
        metavar="K",
        help="override barn_worlds: train on K of BARN's 250 train worlds, evenly spaced and "
        "nested (5 in 50 in 250: the diversity curve); the config must set barn_split: train",
    )
    p.add_argument(
        "--seeds",
        help="train every seed of the config into OUT/seed-<k>/ (e.g. 0-4 or 0,3,7); "
        "--export DIR then ships DIR/seed-<k>/",
    )
    p.add_argument(
        "--n-envs",
        type=int,
        help="override n_envs: simulators in lock-step, one worker process each (0: one per core)",
    )
    p.add_argument(
        "--export", help="also copy the run's policy here when done (e.g. policies/d3dwa)"
    )
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="with --seeds: each seed a Ray task (local, auto, HOST:PORT or ray://HOST:PORT)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def cmd_train(args: argparse.Namespace) -> int:
    # Counts and the config file are checked before torch is imported, so a refusal comes at
    # once; the config's own fields are checked when it is built (load_train_config).
    if args.total_steps is not None and args.total_steps < 1:
        raise ConfigError(f"--total-steps must be >= 1, got {args.total_steps}")
    if args.total_steps is not None:
        MAX_TOTAL_STEPS.check("--total-steps", args.total_steps, "steps")
    if args.barn_worlds is not None and not 1 <= args.barn_worlds <= BARN_TRAIN_SIZE:
        raise ConfigError(
            f"--barn-worlds must be in [1, {BARN_TRAIN_SIZE}] (BARN's train split), "
            f"got {args.barn_worlds}"
        )
    if args.n_envs is not None and args.n_envs < 0:
        raise ConfigError(f"--n-envs must be >= 1 (or 0: one per core), got {args.n_envs}")
    if args.n_envs:
        check_processes("--n-envs", args.n_envs)
    if args.config:
        load_yaml(args.config, ConfigError, "training config")  # size, depth, aliases
    if args.seeds is not None:
        return _train_seeds(args)
    if args.ray is not None:
        raise ConfigError("--ray runs the seeds of --seeds as Ray tasks: give --seeds too")
    # start-up cost: training imports torch (~1 s)
    from d3dwa_bullet.learning.training import (
        TrainConfig,
        check_run_limits,
        export_policy,
        load_train_config,
        train,
    )

    overrides = {
        "method": args.method,
        "total_steps": args.total_steps,
        "seed": args.seed,
        "n_envs": args.n_envs,
        "barn_worlds": args.barn_worlds,
    }
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
    if config is not None:
        check_run_limits(config)
    if args.out:
        out = Path(args.out)
    else:
        assert config is not None
        out = Path("runs") / f"{config.method}__s{config.seed}__{time.strftime('%Y%m%d-%H%M%S')}"
    try:
        summary = train(
            config, out, resume=args.resume, progress=not (args.no_progress or args.json)
        )
    except KeyboardInterrupt:  # a second Ctrl-C or SIGTERM: stopped without saving
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
            f"best greedy evaluation (eval_worlds) at step {best['step']}: success "
            f"{best['success_rate']:.2f}, collisions {best['collision_rate']:.2f}"
        )
    if summary["status"] == "interrupted":
        print(f"checkpoint saved; continue with: d3dwa train --resume --out {out}")
        return 130
    print(f"run: {out}\npolicy: {summary['policy']}")
    if "exported" in summary:
        print(f"exported: {summary['exported']}")
    return 0


def _train_seeds(args: argparse.Namespace) -> int:
    """``--seeds``: one run per seed under --out (``learning.training.seeds``)."""
    seeds = parse_seeds(args.seeds)
    if args.seed is not None:
        raise ConfigError("--seed and --seeds exclude each other: give one")
    if not args.out:
        raise ConfigError("--seeds needs --out DIR (the runs go to DIR/seed-<k>/)")
    if not args.config:
        if not args.method:
            raise ConfigError("--seeds needs --config FILE or --method NAME")
        args.config = str(configs_dir() / f"{args.method}.yaml")
    # start-up cost: training imports torch (~1 s)
    from d3dwa_bullet.learning.training import check_run_limits, load_train_config
    from d3dwa_bullet.learning.training.seeds import SeedOutcome, train_seeds

    config = load_train_config(
        args.config,
        method=args.method,
        total_steps=args.total_steps,
        n_envs=args.n_envs,
        barn_worlds=args.barn_worlds,
    )
    check_run_limits(config)
    quiet = args.no_progress or args.json

    def report(o: SeedOutcome) -> None:
        if args.json:
            return
        what = {"done": "done", "skipped": "already complete", "interrupted": "interrupted",
                "failed": f"FAILED: {o.error}", "stopped": "not started (interrupted)"}[o.status]  # fmt: skip
        print(
            f"seed {o.seed}: {what} ({o.out})" + (f", exported {o.exported}" if o.exported else "")
        )

    try:
        outcomes = train_seeds(config, args.out, seeds, resume=args.resume, export=args.export,
                               progress=not quiet, on_seed=report, ray_address=args.ray)  # fmt: skip
    except KeyboardInterrupt:  # a second Ctrl-C or SIGTERM: stopped without saving
        print(
            f"d3dwa: training aborted; resume with --seeds {args.seeds} --resume", file=sys.stderr
        )
        return 130
    if args.json:
        print(json.dumps([{"seed": o.seed, "out": str(o.out), "status": o.status,
                           "error": o.error, "exported": str(o.exported) if o.exported else None}
                          for o in outcomes]))  # fmt: skip
    failed = [o for o in outcomes if o.status == "failed"]
    if failed:
        names = ", ".join(str(o.seed) for o in failed)
        print(
            f"d3dwa: error: seed(s) {names} failed (the others are kept); continue with "
            f"d3dwa train --config {args.config} --seeds {args.seeds} --out {args.out} --resume",
            file=sys.stderr,
        )
        return 2
    if any(o.status in ("interrupted", "stopped") for o in outcomes):
        print(
            f"d3dwa: interrupted; finished seeds are kept: continue with d3dwa train --config "
            f"{args.config} --seeds {args.seeds} --out {args.out} --resume",
            file=sys.stderr,
        )
        return 130
    return 0
