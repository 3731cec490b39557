"""Options several commands share, and how their text becomes values.

Coordinates (``--start X,Y,YAW``, ``--goal X,Y``, ``--mount X,Y,YAW``), comma lists
(``--methods dwa1,dwa3``), ``--workers``, the episode options (``--noise``, ``--policy``,
rates), ``--time-limit``, worlds (``--world`` / ``--worlds`` with ``--allow-empty``) and the
Ray address. Malformed values raise :class:`ConfigError` naming the option, which ``main``
reports as one line.

Every parser of the command line is a :class:`CommandParser`, which reads a value that
starts with a minus sign and a digit as a value, not an option: ``--start -1,2,0`` and
``--goal -2.5,1.3`` parse as ``--start=-1,2,0`` does (most Gazebo and map_server worlds put
the origin mid-map, so negative coordinates are ordinary).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import warnings
from collections.abc import Callable, Sequence
from typing import NoReturn

from d3dwa_bullet.cli.plan_options import add_global_plan_option, global_plan_arg
from d3dwa_bullet.controllers import default_policy_path, refuse_policy
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError, WorldFormatError
from d3dwa_bullet.limits import (
    MAX_CONTROL_HZ,
    MAX_PHYSICS_HZ,
    MAX_SEED_VALUE,
    MAX_TIME_LIMIT_S,
    check_processes,
)
from d3dwa_bullet.method_specs import FIXED, HELD_REFERENCE, LEARNED, REFERENCE, barn_twin
from d3dwa_bullet.params import RECOVERY_KINDS, PlannerParams, SimParams, recovery_params
from d3dwa_bullet.planning.scan_filter import SCAN_FILTERS
from d3dwa_bullet.sim.backend import BACKENDS, DEFAULT_BACKEND, check_backend
from d3dwa_bullet.world.model import World, goal_in_obstacle, start_in_collision
from d3dwa_bullet.world.registry import load_world, world_file_kind
from randomization.profiles import list_profiles, load_profile

RAY_HELP = (
    "run episodes on Ray: 'local' (a private instance), 'auto' (the cluster of `ray start`), "
    "or HOST:PORT / ray://HOST:PORT"
)
ALLOW_EMPTY_HELP = (
    "accept a Gazebo SDF or map_server world from which no obstacle could be built "
    "(default: refused, naming what was skipped)"
)
_NUMBER = r"(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?|inf(?:inity)?|nan)"
NEGATIVE_VALUE = re.compile(rf"^-{_NUMBER}(?:,\s*[-+]?{_NUMBER})*$", re.IGNORECASE)
"""A negative number or a comma list that starts with one: '-1', '-2.5,1.3', '-1,2,0'
(also '-inf,0': a value, which the option's own check then refuses by name)."""


class CommandParser(argparse.ArgumentParser):
    """An ArgumentParser that takes '-1,2,0' as an option's value, not as an option, and
    reports a bad option in one line.

    argparse reads an argument starting with '-' as an option unless it looks like a
    negative number, and a comma list is not one to it. Its errors print the whole usage
    before the line that names what was wrong; here that line alone is printed (README: any
    bad input ends with one line, exit 2; ``--help`` has the usage). Sub-parsers made with
    ``add_subparsers().add_parser`` are of the same class.
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUE  # what argparse consults (private)

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (--help lists the options)\n")


def parse_floats(text: str, n: int, what: str) -> tuple[float, ...]:
    """'1.0,2.5' -> (1.0, 2.5), finite, with a clear error naming the option."""
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError as err:
        raise ConfigError(f"{what} must be {n} comma-separated numbers, got {text!r}") from err
    if len(vals) != n:
        raise ConfigError(f"{what} must be {n} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise ConfigError(f"{what} must be {n} finite numbers, got {text!r}")
    return vals


def split_list(text: str) -> list[str]:
    """'a, b,,c' -> ['a', 'b', 'c']: a comma list without blanks."""
    return [t.strip() for t in text.split(",") if t.strip()]


def list_arg(text: str | None, option: str, default: Callable[[], Sequence[str]]) -> list[str]:
    """A comma-list option: default() when not given; given, at least one name (an empty
    ``--methods ''`` is refused rather than read as "the default")."""
    if text is None:
        return list(default())
    names = split_list(text)
    if not names:
        raise ConfigError(f"{option} is empty: name at least one, or leave the option out")
    return names


def policy_arg(policy: str | None, methods: Sequence[str]) -> str | None:
    """--policy, which belongs to one learned method: refused beside several --methods
    (it would silently apply to none of them), and for a fixed or reference method (it
    would be ignored)."""
    if policy is not None and len(methods) != 1:
        raise ConfigError(
            f"--policy {policy} needs exactly one method, got --methods {','.join(methods)}"
        )
    if policy is not None:
        refuse_policy(methods[0], policy)
    return policy


def add_policy_root_option(p: argparse.ArgumentParser) -> None:
    """--policy-root DIR (eval, sweep): see :func:`d3dwa_bullet.evaluation.policy_runs.check_policy_root`."""
    p.add_argument(
        "--policy-root",
        metavar="DIR",
        help="each learned method's seed folders from DIR/<method>/seed-<k>/ instead of the shipped "
        "policies/<method>/ (not with --policy); docs/design/learning-protocol.md#policy-root",
    )


def noise_arg(name: str) -> str:
    """--noise checked before any simulator is imported: a shipped profile's name or a profile
    file that loads (randomization's loader, through the bounded YAML loader)."""
    if name != "none":
        load_profile(name)  # ProfileError: one line naming the profile or file
    return name


def seed_arg(value: int, option: str = "--seed") -> int:
    """An episode seed checked: an integer 0..``MAX_SEED_VALUE`` (numpy's and PyBullet's
    seeds; a negative one ends numpy's seeding in a traceback)."""
    if value < 0:
        raise ConfigError(f"{option} must be an integer >= 0, got {value}")
    MAX_SEED_VALUE.check(option, value)
    return value


def time_limit_arg(value: float | None, option: str = "--time-limit") -> float | None:
    """--time-limit checked: None (the world's own) or a finite number of seconds > 0, at
    most ``MAX_TIME_LIMIT_S``."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ConfigError(f"{option} must be a number of seconds > 0, got {value:g}")
    if value is not None:
        MAX_TIME_LIMIT_S.check(option, value, "s")
    return value


def add_world_option(p: argparse.ArgumentParser, flag: str = "--world", **kwargs) -> None:
    """``flag`` (a world name or file) and ``--allow-empty`` (see :func:`load_cli_world`)."""
    p.add_argument(flag, **kwargs)
    p.add_argument("--allow-empty", action="store_true", help=ALLOW_EMPTY_HELP)


def load_cli_world(name_or_path: str, allow_empty: bool = False, warn: bool = True) -> World:
    """The world of a --world value; a Gazebo SDF or map_server file from which no obstacle
    could be built is a WorldFormatError naming what was skipped, unless allow_empty.

    (A native YAML world with no obstacles says so itself and is accepted.) The loader's
    warnings (SDF items skipped) are shown as usual when the world is accepted, unless
    warn=False (a check ahead of a command that loads the world again and warns then).
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = load_world(name_or_path)
    if not world.obstacles and not allow_empty:
        kind = world_file_kind(world.source) if os.path.isfile(world.source) else "native"
        if kind != "native":
            skipped = "; ".join(str(w.message).split(": ", 1)[-1] for w in caught)
            raise WorldFormatError(
                f"{world.source}: no obstacle could be built from this "
                f"{'Gazebo SDF' if kind == 'sdf' else 'map_server'} world"
                f"{f' ({skipped})' if skipped else ''}; pass --allow-empty to use it empty"
            )
    for w in caught if warn else ():
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return world


def add_task_options(p: argparse.ArgumentParser) -> None:
    """--start, --goal and --time-limit: the task on a world (see :func:`load_task_world`)."""
    p.add_argument("--start", help="X,Y,YAW start pose (m, m, rad); negative values as -1,2,0")
    p.add_argument("--goal", help="X,Y goal (m)")
    p.add_argument("--time-limit", type=float, help="episode time limit, s (default 60)")


def load_task_world(args: argparse.Namespace) -> World:
    """The world of --world with --start/--goal/--time-limit applied; a value that is wrong
    for this world (a start in collision, a goal inside an obstacle) names its option."""
    world = load_cli_world(args.world, getattr(args, "allow_empty", False))
    start = parse_floats(args.start, 3, "--start X,Y,YAW") if args.start else None
    goal = parse_floats(args.goal, 2, "--goal X,Y") if args.goal else None
    time_limit = time_limit_arg(args.time_limit)
    if start is not None and start_in_collision(world, start):
        raise ConfigError(
            f"--start {args.start} puts the robot body in collision with an obstacle of "
            f"{world.source}"
        )
    if goal is not None and goal_in_obstacle(world, goal):
        raise ConfigError(f"--goal {args.goal} lies inside an obstacle of {world.source}")
    if start is None and goal is None and time_limit is None:
        return world
    try:
        return world.with_task(start=start, goal=goal, time_limit=time_limit)
    except WorldFormatError as err:
        if os.path.isfile(world.source) and world_file_kind(world.source) != "native":
            raise WorldFormatError(
                f"{err} (a placeholder: this file has no task of its own; give --start and --goal)"
            ) from err
        raise


#: --noise's help: every shipped profile, read from the profiles folder, never typed here.
NOISE_HELP = f"randomisation profile: {', '.join(list_profiles())}, or a YAML path"


def add_episode_options(p: argparse.ArgumentParser) -> None:
    """--noise, --policy, --json and the two rates, as `d3dwa run` and `d3dwa eval` take them."""
    p.add_argument(
        "--noise",
        default="none",
        help=NOISE_HELP,
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
    add_recovery_options(p)
    add_sim_backend_option(p)
    add_global_plan_option(p)


def add_sim_backend_option(p: argparse.ArgumentParser) -> None:
    """--backend: the simulator that runs the episodes (docs/design/backends.md)."""
    p.add_argument(
        "--backend",
        default=DEFAULT_BACKEND,
        help=f"simulator: {', '.join(BACKENDS)} (pybullet: the default and the reference; kinematic: "
        "a 2D ray cast and wheel kinematics, about 5x cheaper, equivalent only where "
        "docs/pilots/kinematic-agreement/ reads so)",
    )


def add_recovery_options(p: argparse.ArgumentParser) -> None:
    """--recovery and the progress checker's --progress-radius / --progress-window."""
    p.add_argument(
        "--recovery",
        default="none",
        help="recovery layer around the controller: none (the paper's stack, default) or "
        "nav2 (progress checker + spin / back-up, beyond the paper; docs/design/recovery.md#recovery)",
    )
    p.add_argument(
        "--scan-filter",
        default="none",
        help=f"scan filter before the observation and the planner: {', '.join(SCAN_FILTERS)} "
        "(none: the paper's stack, default; beyond the paper: docs/design/scan-filter.md#scan-filter)",
    )
    p.add_argument(
        "--progress-radius", type=float, help="with --recovery: movement radius, m (default 0.5)"
    )
    p.add_argument(
        "--progress-window", type=float, help="with --recovery: time allowance, s (default 10)"
    )


def recovery_arg(args: argparse.Namespace, control_period: float):
    """The RecoveryParams of --recovery (None for none), its checker's radius and window
    checked by option name: > 0, finite, a window no shorter than one control period."""
    kind = getattr(args, "recovery", "none")
    if kind not in RECOVERY_KINDS:
        raise ConfigError(f"--recovery {kind!r}: choose one of {', '.join(RECOVERY_KINDS)}")
    radius, window = getattr(args, "progress_radius", None), getattr(args, "progress_window", None)
    for option, value in (("--progress-radius", radius), ("--progress-window", window)):
        if value is None:
            continue
        if kind == "none":
            raise ConfigError(f"{option} needs a recovery layer (--recovery nav2)")
        if not (math.isfinite(value) and value > 0):
            raise ConfigError(f"{option} must be a number > 0, got {value:g}")
    if window is not None and window < control_period:
        raise ConfigError(
            f"--progress-window {window:g} s is shorter than one control step "
            f"({control_period:g} s)"
        )
    return recovery_params(kind, radius, window)


def episode_config(args: argparse.Namespace) -> EpisodeConfig:
    """EpisodeConfig from --physics-hz / --control-hz (checked: physics must divide evenly,
    neither over its limit in :mod:`d3dwa_bullet.limits`) and, on commands that take it, --recovery (see :func:`recovery_arg`)."""
    MAX_PHYSICS_HZ.check("--physics-hz", args.physics_hz, "Hz")
    MAX_CONTROL_HZ.check("--control-hz", args.control_hz, "Hz")
    sim = SimParams(physics_hz=args.physics_hz, control_hz=args.control_hz)
    return EpisodeConfig(
        sim=sim,
        planner=PlannerParams(control_period=sim.control_period),
        recovery=recovery_arg(args, sim.control_period),
        scan_filter=scan_filter_arg(args),
        backend=check_backend(
            getattr(args, "backend", DEFAULT_BACKEND), getattr(args, "gui", False)
        ),
        global_plan=global_plan_arg(args),
    )


def scan_filter_arg(args: argparse.Namespace) -> str:
    """--scan-filter, checked (ConfigError naming the option and the known names)."""
    name = getattr(args, "scan_filter", "none")
    if name not in SCAN_FILTERS:
        raise ConfigError(f"--scan-filter {name!r}: choose one of {', '.join(SCAN_FILTERS)}")
    return name


def add_backend_options(p: argparse.ArgumentParser) -> None:
    """--workers and --ray: where a command's episodes run."""
    p.add_argument("--workers", type=int, help="processes, >= 1 (default: all cores)")
    p.add_argument("--ray", metavar="ADDRESS", help=RAY_HELP)


def workers_arg(args: argparse.Namespace) -> int:
    """--workers, default (not given) all cores; refuses a count below 1 (0 used to mean all
    cores, read by a user as "none"), and more local processes than
    :func:`d3dwa_bullet.limits.max_processes` (Ray's workers are the cluster's)."""
    if args.workers is None:
        return os.cpu_count() or 1
    if args.workers < 1:
        raise ConfigError(
            f"--workers must be >= 1, got {args.workers} (leave it out for all cores)"
        )
    if getattr(args, "ray", None) in (None, "local"):
        check_processes("--workers", args.workers)
    return args.workers


def default_methods(policy_root: str | None = None) -> list[str]:
    """The paper's track: fixed baselines, the reference methods drawn every control step
    (SPEC 6's floor) and held for the shipped policies' decision period (the floor a learned
    method must clear), then every learned method whose shipped policy exists (or whose folder
    ``--policy-root`` holds), but for those
    trained on BARN (``-barn``): they are asked on BARN, by name (docs/pilots/barn-trained/plan.md),
    and fifteen more policies on every default run would take the main job past its 10 minutes."""
    learned = [
        m for m in LEARNED if default_policy_path(m, policy_root).exists() and barn_twin(m) is None
    ]
    return list(FIXED) + list(REFERENCE) + list(HELD_REFERENCE) + learned


def add_reuse_options(p: argparse.ArgumentParser) -> None:
    """--reuse DIR and --reuse-check K (eval, sweep): see :mod:`d3dwa_bullet.evaluation.reuse`."""
    p.add_argument(
        "--reuse",
        metavar="DIR",
        help="take the episodes another results directory provably ran the same (same config, "
        "policies, worlds) instead of running them; docs/design/metrics.md#reuse",
    )
    p.add_argument(
        "--reuse-check",
        type=int,
        default=3,
        metavar="K",
        help="reusable episodes rerun first, evenly spaced, plus the first of each method and "
        "profile, and compared cell by cell with DIR's (default 3, >= 1)",
    )
