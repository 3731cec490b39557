"""Argument handling for ``d3dwa replay``, ``d3dwa record`` and ``d3dwa compare-scans``.

``d3dwa_bullet.cli`` owns the parser: it calls ``add_*_arguments(subparser)`` and dispatches
to ``run_*(args, ...)``, which return the exit code. What only the simulator side knows
comes in as callables: ``make_step_fn(method, policy_path) -> step_fn`` for the replay and
``run_episode(world, method, policy_path, noise, seed, recorder)`` for recording. Errors are
raised as ``D3DWAError`` subclasses (``BagFormatError``, ...) for ``main`` to report.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.scan import Pose2D

from .bag_writer import BagRecorder
from .compare import compare_scans, format_scan_comparison
from .replay import ReplayResult, StepFn, observe_only, replay_bag
from .topics import TopicMap

#: Replay method that needs no simulator-side code: observations only, no decision.
OBSERVE_METHOD = "observe"


def parse_floats(text: str, n: int, what: str) -> tuple[float, ...]:
    """'1.0,2.5' -> (1.0, 2.5); BagFormatError naming the option if malformed."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != n:
        raise BagFormatError(f"{what} needs {n} comma-separated numbers, got {text!r}")
    return values


def parse_topic_overrides(items: list[str] | None) -> TopicMap:
    """['scan=/scan', 'imu='] -> TopicMap with scan='/scan' and imu disabled."""
    topics = TopicMap()
    roles = topics.roles()
    changes: dict[str, str | None] = {}
    for item in items or []:
        role, sep, name = item.partition("=")
        if not sep or role not in roles:
            raise BagFormatError(
                f"--topic expects ROLE=NAME with ROLE in {list(roles)}, got {item!r}"
            )
        changes[role] = name or None
    return replace(topics, **changes)


def _add_bag_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--topic",
        action="append",
        metavar="ROLE=NAME",
        help="override a topic (roles: " + ", ".join(TopicMap().roles()) + "); ROLE= disables it",
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def add_replay_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bag", type=Path, help="ROS 1 .bag, ROS 2 bag directory, .db3 or .mcap")
    parser.add_argument("--method", default=OBSERVE_METHOD, help="method name (dwa1, ..., d3dwa)")
    parser.add_argument("--policy", type=Path, help="checkpoint for learned methods")
    parser.add_argument("--goal", help="X,Y goal in the odometry frame (default: first /goal_pose)")
    parser.add_argument("--mount", help="X,Y,YAW lidar pose in base_link (default: from tf)")
    parser.add_argument(
        "--clock", choices=("auto", "header", "receive"), default="auto", help="replay clock"
    )
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    _add_bag_options(parser)


def describe_replay(result: ReplayResult) -> str:
    """Human-readable summary: topics used and how they were chosen, clock, counts, files."""
    lines = [f"bag: {result.bag}"]
    lines += [f"  {role:15s} {topic or '-'}" for role, topic in result.topics.items()]
    lines += [f"note: {n}" for n in result.notes]
    m = result.mount
    lines.append(f"mount: ({m.x:.3f}, {m.y:.3f}, yaw {m.yaw:.3f}) from {result.mount_source}")
    lines.append(f"goal: ({result.goal[0]:.3f}, {result.goal[1]:.3f}) from {result.goal_source}")
    skipped = ", ".join(f"{k}: {v}" for k, v in sorted(result.skipped.items())) or "none"
    lines.append(f"scans: {result.scans}, replayed: {result.replayed}, skipped: {skipped}")
    lines += [f"wrote {p}" for p in result.files.values()]
    return "\n".join(lines)


def run_replay(
    args: argparse.Namespace,
    make_step_fn: Callable[[str, Path | None], StepFn] | None = None,
    out: TextIO = sys.stdout,
) -> int:
    """``d3dwa replay``. Exit code 0 if any scan was replayed, 1 if none was."""
    if args.method == OBSERVE_METHOD:
        step_fn: StepFn = observe_only
    elif make_step_fn is None:
        raise BagFormatError(f"replay method {args.method!r} is not available in this build")
    else:
        step_fn = make_step_fn(args.method, args.policy)
    goal = parse_floats(args.goal, 2, "--goal") if args.goal else None
    mount = Pose2D(*parse_floats(args.mount, 3, "--mount")) if args.mount else None
    result = replay_bag(
        args.bag,
        step_fn=step_fn,
        goal=goal,
        topics=parse_topic_overrides(args.topic),
        mount=mount,
        out_dir=args.out,
        clock=args.clock,
        plots=not args.no_plots,
    )
    if args.json:
        out.write(json.dumps(result.summary(), indent=2) + "\n")
    else:
        out.write(describe_replay(result) + "\n")
    return 0 if result.replayed else 1


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", required=True, help="world name or file")
    parser.add_argument("--method", required=True, help="method name")
    parser.add_argument("--policy", type=Path, help="checkpoint for learned methods")
    parser.add_argument("--out", type=Path, required=True, help="bag path (directory, or .bag)")
    parser.add_argument("--noise", default="none", help="randomisation profile name")
    parser.add_argument("--seed", type=int, default=0, help="episode seed")
    parser.add_argument("--storage", choices=("sqlite3", "mcap", "ros1"), default="sqlite3")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bag")


def run_record(
    args: argparse.Namespace,
    run_episode: Callable[..., Any],
    out: TextIO = sys.stdout,
) -> int:
    """``d3dwa record``: ``run_episode(world, method, policy, noise, seed, recorder)`` drives
    the simulator and calls ``recorder.write_step(...)`` once per control step."""
    with BagRecorder(args.out, storage=args.storage, overwrite=args.overwrite) as recorder:
        episode = run_episode(args.world, args.method, args.policy, args.noise, args.seed, recorder)
    counts = ", ".join(f"{t}: {n}" for t, n in sorted(recorder.counts.items()))
    out.write(f"wrote {args.out} ({counts})\n")
    if episode is not None:
        out.write(f"episode: {episode}\n")
    return 0


def add_compare_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bag_a", type=Path, help="first bag (e.g. simulated)")
    parser.add_argument("bag_b", type=Path, help="second bag (e.g. real)")
    _add_bag_options(parser)


def run_compare(args: argparse.Namespace, out: TextIO = sys.stdout) -> int:
    """``d3dwa compare-scans A B``: Markdown table, or JSON with --json."""
    result = compare_scans(args.bag_a, args.bag_b, topics=parse_topic_overrides(args.topic))
    if args.json:
        out.write(json.dumps(result, indent=2) + "\n")
    else:
        out.write(format_scan_comparison(result))
    return 0
