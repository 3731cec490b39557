"""Argument handling for ``d3dwa replay``, ``d3dwa record`` and ``d3dwa compare-scans``.

``d3dwa_bullet.cli`` owns the parser: it calls ``add_*_arguments(subparser)`` and dispatches
to ``run_*(args, ...)``, which return the exit code. What only the simulator side knows
comes in as callables: ``make_step_fn(method, policy_path, seed=..., estimator=...) -> step_fn`` for
the replay and ``run_episode(world, method, policy_path, noise, seed, recorder)`` (plus
``time_limit=`` when ``--time-limit`` is given) for recording. Errors are raised as
``D3DWAError`` subclasses (``BagFormatError``, ...) for ``main`` to report; whatever was
replayed before an error is on disk by then (``replay.csv``, ``summary.json``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from d3dwa_bullet.cli.options import (
    ALLOW_EMPTY_HELP,
    add_recovery_options,
    load_cli_world,
    parse_floats,
    recovery_arg,
    scan_filter_arg,
    seed_arg,
    time_limit_arg,
)
from d3dwa_bullet.cli.output import check_out_dir, json_text
from d3dwa_bullet.cli.plan_options import add_global_plan_option, global_plan_arg
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.errors import BagFormatError, ConfigError, D3DWAError
from d3dwa_bullet.params import SimParams
from d3dwa_bullet.sim.scan import Pose2D
from transfer.bag_writer import (
    BAG_VERSIONS,
    DEFAULT_BAG_VERSION,
    STORAGES,
    BagRecorder,
    check_bag_version,
    resolve_storage,
)
from transfer.compare import compare_scans, describe_skipped, format_scan_comparison
from transfer.replay import replay_bag
from transfer.replay_output import ReplayResult
from transfer.replay_step import ESTIMATORS, StepFn, observe_only
from transfer.topics import TopicMap

#: Replay method that needs no simulator-side code: observations only, no decision.
OBSERVE_METHOD = "observe"


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
    parser.add_argument(
        "--estimator",
        choices=ESTIMATORS,
        default="odometry",
        help="pose/velocity source: the bag's fused odometry (default; bit-exact against the "
        "simulator) or 'ekf', re-fusing wheel odometry and IMU (robots without fused odometry)",
    )
    parser.add_argument(
        "--seed", type=int, default=0,
        help="episode seed the `random` method draws from (default 0; the --seed a bag was "
        "recorded with replays its actions)",
    )  # fmt: skip
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
    make_step_fn: Callable[..., StepFn] | None = None,
    out: TextIO | None = None,
) -> int:
    """``d3dwa replay``. Exit code 0 if any scan was replayed.

    If none was, the summary is still printed (and written to ``--out``), then a
    ``BagFormatError`` says why. An unexpected failure inside the step function (a bug, or
    data the pipeline cannot digest) becomes a ``D3DWAError`` naming the bag and the
    partial results, instead of a traceback.
    """
    out = sys.stdout if out is None else out
    estimator = getattr(args, "estimator", "odometry")
    if args.method == OBSERVE_METHOD:
        if estimator != "odometry":
            raise ConfigError(
                f"--estimator {estimator} needs a decision method (--method dwa1, ..., d3dwa)"
            )
        step_fn: StepFn = observe_only
    elif make_step_fn is None:
        raise BagFormatError(f"replay method {args.method!r} is not available in this build")
    else:
        options = {"estimator": estimator} if estimator != "odometry" else {}
        step_fn = make_step_fn(args.method, args.policy, seed=getattr(args, "seed", 0), **options)
    goal = parse_floats(args.goal, 2, "--goal") if args.goal else None
    mount = Pose2D(*parse_floats(args.mount, 3, "--mount")) if args.mount else None
    check_out_dir(args.out)
    with locked_dir(args.out):  # one writer: replay.csv, summary.json, figures
        try:
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
        except D3DWAError:
            raise
        except KeyboardInterrupt as err:
            raise KeyboardInterrupt(
                f"the scans replayed so far are in {Path(args.out) / 'replay.csv'}"
            ) from err
        except Exception as err:  # noqa: BLE001 - reported as one line; rows so far are on disk
            raise D3DWAError(
                f"{args.bag}: replay with {args.method!r} stopped: {type(err).__name__}: {err}; "
                f"scans replayed before the failure are in {Path(args.out) / 'replay.csv'}"
            ) from err
    if args.json:
        out.write(json_text(result.summary(), indent=2) + "\n")
    else:
        out.write(describe_replay(result) + "\n")
    if not result.replayed:
        raise BagFormatError(nothing_replayed(result))
    return 0


def nothing_replayed(result: ReplayResult) -> str:
    """One line: why no scan of the bag was replayed."""
    topic = result.topics.get("scan")
    why = ", ".join(f"{n} {k}" for k, n in sorted(result.skipped.items())) or "no scans"
    overlap = [n for n in result.notes if n.startswith("no scan overlaps")]
    extra = f"; {overlap[0]} (odometry topic {result.topics.get('odometry')!r})" if overlap else ""
    where = f"; summary in {result.files['summary']}" if "summary" in result.files else ""
    return (
        f"{result.bag}: no scan on {topic!r} could be replayed "
        f"({result.scans} messages: {why}){extra}{where}"
    )


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", required=True, help="world name or file")
    parser.add_argument("--allow-empty", action="store_true", help=ALLOW_EMPTY_HELP)
    parser.add_argument("--method", required=True, help="method name")
    parser.add_argument("--policy", type=Path, help="checkpoint for learned methods")
    parser.add_argument(
        "--out", type=Path, required=True,
        help="bag path: a ROS 2 bag directory (x.mcap: an MCAP one), or x.bag (ROS 1)",
    )  # fmt: skip
    parser.add_argument("--noise", default="none", help="randomisation profile name")
    parser.add_argument("--seed", type=int, default=0, help="episode seed")
    parser.add_argument("--time-limit", type=float, help="episode time limit, s (default: world's)")
    parser.add_argument(
        "--storage", choices=STORAGES,
        help="bag storage (default: from the --out suffix, .mcap: mcap, .bag: ros1; else sqlite3)",
    )  # fmt: skip
    parser.add_argument(
        "--bag-version", type=int, metavar="N",
        help=f"rosbag2 metadata version of a ROS 2 bag: {' or '.join(map(str, BAG_VERSIONS))} "
        f"(default {DEFAULT_BAG_VERSION}, which ROS 2 Humble reads; 9: Jazzy and later only)",
    )  # fmt: skip
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bag")
    add_recovery_options(parser)
    add_global_plan_option(parser)


def run_record(
    args: argparse.Namespace,
    run_episode: Callable[..., Any],
    out: TextIO | None = None,
) -> int:
    """``d3dwa record``: ``run_episode(world, method, policy, noise, seed, recorder)`` drives
    the simulator and calls ``recorder.write_step(...)`` once per control step.

    A failure before the first message (unknown world or method, missing policy) leaves no
    bag behind; a failure halfway keeps the steps recorded so far in a readable bag, and
    so does Ctrl-C (the KeyboardInterrupt is re-raised with what the bag holds). An existing
    ``--out`` is refused unless ``--overwrite``; the world is checked (``--allow-empty``)
    and ``--time-limit`` too before the bag is created.
    """
    out = sys.stdout if out is None else out
    extra = {}
    if time_limit_arg(getattr(args, "time_limit", None)) is not None:
        extra["time_limit"] = args.time_limit
    seed_arg(args.seed)
    recovery = recovery_arg(args, SimParams().control_period)
    scan_filter, plan = scan_filter_arg(args), global_plan_arg(args)
    if recovery is not None or scan_filter != "none" or plan is not None:
        # start-up cost: d3dwa_bullet.episode imports pybullet, needed only to record
        from d3dwa_bullet.episode import EpisodeConfig

        extra["config"] = EpisodeConfig(
            recovery=recovery, scan_filter=scan_filter, global_plan=plan
        )
    load_cli_world(args.world, getattr(args, "allow_empty", False), warn=False)
    target = Path(args.out)
    if target.exists() and not args.overwrite:
        if looks_like_bag(target):
            raise BagFormatError(f"{target}: bag exists; pass --overwrite to replace it")
        raise BagFormatError(f"{target}: exists and is not a bag; choose another --out")
    storage = resolve_storage(args.out, args.storage, option="--storage")
    version = check_bag_version(
        getattr(args, "bag_version", None), storage, args.out, option="--bag-version"
    )
    recorder = BagRecorder(args.out, storage=storage, version=version, overwrite=args.overwrite)
    try:
        with recorder:
            episode = run_episode(
                args.world, args.method, args.policy, args.noise, args.seed, recorder, **extra
            )
    except BaseException as err:
        if not recorder.counts:
            recorder.discard()
        kept = (
            f"the bag keeps the {sum(recorder.counts.values())} messages written"
            if recorder.counts
            else "no bag written"
        )
        if isinstance(err, KeyboardInterrupt):
            raise KeyboardInterrupt(f"{args.out}: recording stopped; {kept}") from err
        if isinstance(err, D3DWAError) or not isinstance(err, Exception):
            raise
        raise D3DWAError(
            f"{args.out}: recording stopped: {type(err).__name__}: {err}; {kept}"
        ) from err
    counts = ", ".join(f"{t}: {n}" for t, n in sorted(recorder.counts.items()))
    out.write(f"wrote {args.out} ({counts})\n")
    if episode is not None:
        out.write(f"episode: {episode}\n")
    return 0


def looks_like_bag(path: Path) -> bool:
    """A ROS 2 bag directory (metadata.yaml) or a bag file (.bag, .db3, .mcap)."""
    if path.is_dir():
        return (path / "metadata.yaml").exists()
    return path.suffix in (".bag", ".db3", ".mcap")


def add_compare_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bag_a", type=Path, help="first bag (e.g. simulated)")
    parser.add_argument("bag_b", type=Path, help="second bag (e.g. real)")
    _add_bag_options(parser)


def run_compare(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``d3dwa compare-scans A B``: Markdown table, or JSON with --json.

    Scan messages that are not scans (zero beams, bad geometry, corrupt) are left out and
    counted (a line above the table, ``skipped`` in the JSON); a bag with no scan left is a
    BagFormatError naming it and why, as there is nothing to compare.
    """
    out = sys.stdout if out is None else out
    result = compare_scans(args.bag_a, args.bag_b, topics=parse_topic_overrides(args.topic))
    empty = [s for s in (result["a"], result["b"]) if not s["scans"]]
    if empty:
        raise BagFormatError(
            "; ".join(
                f"{s['bag']}: no scan on {s['topic']!r} to compare ({s['scan_messages']} "
                f"messages{': ' + describe_skipped(s) if s.get('skipped') else ''})"
                for s in empty
            )
        )
    if args.json:
        out.write(json_text(result, indent=2) + "\n")
    else:
        out.write(format_scan_comparison(result))
    return 0
