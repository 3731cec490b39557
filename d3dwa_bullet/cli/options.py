"""Options several commands share, and how their text becomes values.

Coordinates (``--start X,Y,YAW``, ``--goal X,Y``, ``--mount X,Y,YAW``), comma lists
(``--methods dwa1,dwa3``), ``--workers``, the episode options (``--noise``, ``--policy``,
rates) and the Ray address. Malformed values raise :class:`ConfigError` naming the option,
which ``main`` reports as one line.
"""

from __future__ import annotations

import argparse
import os

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import PlannerParams, SimParams
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import load_world

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
    """'a, b,,c' -> ['a', 'b', 'c']: a comma list without blanks."""
    return [t.strip() for t in text.split(",") if t.strip()]


def add_task_options(p: argparse.ArgumentParser) -> None:
    """--start, --goal and --time-limit: the task on a world (see :func:`load_task_world`)."""
    p.add_argument("--start", help="X,Y,YAW start pose (m, m, rad)")
    p.add_argument("--goal", help="X,Y goal (m)")
    p.add_argument("--time-limit", type=float, help="episode time limit, s (default 60)")


def load_task_world(args: argparse.Namespace) -> World:
    """The world of --world with --start/--goal/--time-limit applied."""
    world = load_world(args.world)
    start = parse_floats(args.start, 3, "--start X,Y,YAW") if args.start else None
    goal = parse_floats(args.goal, 2, "--goal X,Y") if args.goal else None
    if start or goal or args.time_limit:
        world = world.with_task(start=start, goal=goal, time_limit=args.time_limit)
    return world


def add_episode_options(p: argparse.ArgumentParser) -> None:
    """--noise, --policy, --json and the two rates, as `d3dwa run` and `d3dwa eval` take them."""
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


def episode_config(args: argparse.Namespace):
    """EpisodeConfig from --physics-hz / --control-hz (checked: physics must divide evenly)."""
    # start-up cost: d3dwa_bullet.episode imports pybullet and scipy (~0.5 s)
    from d3dwa_bullet.episode import EpisodeConfig

    sim = SimParams(physics_hz=args.physics_hz, control_hz=args.control_hz)
    return EpisodeConfig(sim=sim, planner=PlannerParams(control_period=sim.control_period))


def add_backend_options(p: argparse.ArgumentParser) -> None:
    """--workers and --ray: where a command's episodes run."""
    p.add_argument("--workers", type=int, default=0, help="processes (default: all cores)")
    p.add_argument("--ray", metavar="ADDRESS", help=RAY_HELP)


def workers_arg(args: argparse.Namespace) -> int:
    """--workers, default all cores; refuses negative counts."""
    if args.workers < 0:
        raise ConfigError(f"--workers must be >= 0 (0 = all cores), got {args.workers}")
    return args.workers or os.cpu_count() or 1


def default_methods() -> list[str]:
    """Fixed baselines plus every learned method whose shipped policy exists."""
    # start-up cost: d3dwa_bullet.methods imports numba (the planner), ~0.15 s
    from d3dwa_bullet.methods import FIXED, LEARNED, default_policy_path

    return list(FIXED) + [m for m in LEARNED if default_policy_path(m).exists()]
