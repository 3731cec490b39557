"""``d3dwa drive``: a method drives a Kachaka (or ``d3dwa serve``) through the Kachaka API; a
learned one from its checkpoint (torch) or from an ONNX export (``--onnx``, onnxruntime).

Everything that can be refused without the robot is refused before connecting (method,
policy, goal and limits, the ``--record`` destination), so a bad command line sends nothing.
Once connected, every way out stops the robot; an error's one line says whether the stop
was acknowledged and what the bag kept. Progress goes to stderr once a second, the summary
(as ``d3dwa run`` prints it, ``--json`` too) to stdout.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from d3dwa_bullet.cli.options import (
    add_recovery_options,
    parse_floats,
    recovery_arg,
    scan_filter_arg,
    time_limit_arg,
)
from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.cli.plan_options import add_global_plan_option, global_plan_arg
from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.errors import ConfigError, D3DWAError, WorldFormatError
from d3dwa_bullet.method_specs import METHODS, check_method
from d3dwa_bullet.params import SimParams, TerminationParams
from d3dwa_bullet.planning.global_plan_params import GlobalPlanParams
from d3dwa_bullet.world.map_server import load_map_world
from d3dwa_bullet.world.model import World

ROBOT_EXTRA = 'pip install "d3dwa-bullet[robot]"'


def robot_extra(command: str) -> ModuleType:
    """``d3dwa_bullet.live``, or a ConfigError telling how to install the robot extra.

    gRPC's C core is kept quiet (``GRPC_VERBOSITY=NONE`` unless the user set it): it would
    log its own lines to stderr before the command's one-line error."""
    os.environ.setdefault("GRPC_VERBOSITY", "NONE")  # read when grpc's core starts
    try:
        # optional dependency: grpc and kachaka_api come with the robot extra only
        return importlib.import_module("d3dwa_bullet.live")
    except ImportError as err:
        raise ConfigError(
            f"d3dwa {command} needs the robot extra ({err.name or err}): {ROBOT_EXTRA}"
        ) from err


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("drive", help="drive a Kachaka (or `d3dwa serve`) with a method")
    p.add_argument("--kachaka", required=True, metavar="HOST[:PORT]", help="robot address")
    p.add_argument("--goal", required=True, help="X,Y goal in the robot's odometry frame (m)")
    p.add_argument(
        "--method", required=True,
        help=f"one of {', '.join(METHODS)}, or package.module:Name / an installed method (d3dwa methods)",
    )  # fmt: skip
    p.add_argument("--policy", help="checkpoint directory for a learned method")
    p.add_argument(
        "--onnx", metavar="FILE",
        help="an ONNX policy from `d3dwa export --onnx` (instead of --policy): runs on "
        "onnxruntime, so the robot's computer needs no torch",
    )  # fmt: skip
    p.add_argument(
        "--estimator", choices=("odometry", "ekf"), default="odometry",
        help="pose source: the robot's fused odometry (default) or the EKF over its wheel "
        "odometry and IMU, as `d3dwa replay --estimator`",
    )  # fmt: skip
    add_recovery_options(p)
    add_global_plan_option(p)
    p.add_argument(
        "--map", type=Path, metavar="FILE",
        help="the map --global-plan map plans on: a map_server YAML (+ its image) in the robot's map frame "
        "(where the robot reports its pose on its map)",
    )  # fmt: skip
    p.add_argument("--record", type=Path, metavar="BAG", help="write the run as a ROS 2 bag")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --record bag")
    p.add_argument("--time-limit", type=float, help="s (default 60)")
    p.add_argument(
        "--speed-limit", default="0.3,1.57", metavar="V,W",
        help="clamp every command to |v| <= V m/s, |w| <= W rad/s (default: Kachaka's API limits)",
    )  # fmt: skip
    p.add_argument(
        "--lockstep", action="store_true",
        help="the robot advances one control period per command (`d3dwa serve --lockstep`): "
        "do not pace the loop by the wall clock, and count a stamp's age in commands",
    )  # fmt: skip
    p.add_argument(
        "--stale", type=float, metavar="S",
        help="refuse a scan or odometry older than S seconds (default: two control periods; "
        "with --lockstep, S / control period commands)",
    )  # fmt: skip
    p.add_argument("--watchdog", type=float, default=0.5, help="stop if a step takes longer, s")
    p.add_argument("--timeout", type=float, default=0.5, help="deadline of each API call, s")
    p.add_argument("--connect-timeout", type=float, default=3.0, help="s to reach the robot")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_drive, interrupted="nothing was sent to the robot")


def _seconds(value: float, option: str) -> float:
    if not (value > 0 and value < float("inf")):
        raise ConfigError(f"{option} must be a number of seconds > 0, got {value:g}")
    return value


def cmd_drive(args: argparse.Namespace) -> int:
    # Input is checked before the robot extra, the simulator or torch is imported.
    goal = parse_floats(args.goal, 2, "--goal X,Y")
    limits = parse_floats(args.speed_limit, 2, "--speed-limit V,W")
    if min(limits) <= 0:
        raise ConfigError(f"--speed-limit must be two numbers > 0, got {args.speed_limit!r}")
    for option, value in (
        ("--watchdog", args.watchdog), ("--timeout", args.timeout),
        ("--connect-timeout", args.connect_timeout), ("--stale", args.stale),
    ):  # fmt: skip
        if value is not None:
            _seconds(value, option)
    time_limit = time_limit_arg(args.time_limit) or TerminationParams().time_limit
    plan = global_plan_arg(args)
    known_map = _known_map(args.map, plan)
    config = EpisodeConfig(
        recovery=recovery_arg(args, SimParams().control_period), scan_filter=scan_filter_arg(args),
        global_plan=plan,
    )  # fmt: skip
    check_method(args.method)
    if args.onnx is not None and args.policy is not None:
        raise ConfigError(
            f"--onnx {args.onnx} and --policy {args.policy} both name the policy: give one"
        )
    if args.record is not None and args.record.exists() and not args.overwrite:
        raise ConfigError(f"--record {args.record}: exists; pass --overwrite to replace it")
    live = robot_extra("drive")
    # start-up cost: the policy (torch, or onnxruntime) and transfer's replay step (pybullet)
    from d3dwa_bullet.controllers import make_controller
    from transfer.bag_writer import BagRecorder
    from transfer.sim_bridge import ReplayPipeline

    settings = live.DriveSettings(
        goal=goal, time_limit=time_limit, limits=live.SpeedLimits(*limits),
        stale_s=args.stale, watchdog_s=args.watchdog, lockstep=args.lockstep,
    )  # fmt: skip
    controller = make_controller(args.method, args.policy, onnx=args.onnx)
    if controller.policy is not None and not args.json:  # its terms, as `run` prints them
        print(f"policy: {controller.source}", flush=True)
    pipeline = ReplayPipeline(
        controller, estimator=args.estimator, config=config, known_map=known_map
    )
    live.warm_up(pipeline)
    recorder = None
    if args.record is not None:
        recorder = BagRecorder(args.record, goal=goal, overwrite=args.overwrite)
    result = live.DriveResult()
    hook = live.DriveRecorder(recorder) if recorder is not None else None
    address = "the robot"
    try:
        # the bag is opened before connecting: a bag that cannot be written costs no command
        with recorder if recorder is not None else contextlib.nullcontext():
            link = live.KachakaLink(  # RobotLinkError: unreachable, nothing sent
                args.kachaka, timeout=args.timeout, connect_timeout=args.connect_timeout
            )
            address = link.address
            try:
                live.drive(
                    link, pipeline, settings, result=result, on_step=hook,
                    on_progress=_progress_printer(config.sim.control_hz), on_plan=_plan_printer,
                )  # fmt: skip
            finally:
                link.close()
                if hook is not None and result.stopped:
                    hook.stopped()
    except KeyboardInterrupt as err:
        raise KeyboardInterrupt(_after(result, recorder)) from err
    except D3DWAError as err:
        raise type(err)(f"{err}{_after(result, recorder, '; ')}") from err
    except Exception as err:  # noqa: BLE001 - any failure in the loop: one line, robot stopped
        raise D3DWAError(
            f"drive failed: {type(err).__name__}: {err}{_after(result, recorder, '; ')}"
        ) from err
    summary = result.summary(
        args.method, address, config.sim.control_period, config.recovery_name,
        config.global_plan_name,
    )  # fmt: skip
    _print_summary(summary, args.json, recorder)
    return 0


def _known_map(path: Path | None, plan: GlobalPlanParams | None) -> World | None:
    """The map --global-plan map plans on, loaded before anything connects (None for another
    plan); ConfigError (one line) without --map, for --map without ``map``, or naming the file
    that does not load."""
    kind = "none" if plan is None else plan.kind
    if kind != "map":
        if path is not None:
            raise ConfigError(f"--map {path} is read only with --global-plan map (got {kind})")
        return None
    if path is None:
        raise ConfigError(
            "--global-plan map on drive needs --map FILE: the robot's map as a map_server YAML "
            "(+ its image)"
        )
    try:
        return load_map_world(path)
    except WorldFormatError as err:
        raise ConfigError(f"--map {path} does not load: {err}") from err


def _plan_printer(step: int, status: str, note: str) -> None:
    print(f"step {step}: global plan {status}: {note}", file=sys.stderr, flush=True)


def _after(result: Any, recorder: Any, lead: str = "") -> str:
    """What a run that ended early left, after lead: the stop (nothing when no command was
    ever sent, or the robot was never reached), the steps, the bag."""
    if result.stopped is None:
        stop = ""
    elif result.stopped:
        stop = f"the robot was stopped after {result.steps} commands"
    else:
        stop = f"the stop after {result.steps} commands was not acknowledged (connection lost)"
    parts = [stop] if stop else []
    if recorder is not None:
        if recorder.counts:
            parts.append(f"{recorder.path} keeps {sum(recorder.counts.values())} messages")
        else:
            recorder.discard()
            parts.append("no bag written")
    return lead + "; ".join(parts) if parts else ""


def _progress_printer(every: int):
    def show(step: int, distance: float, command: tuple[float, float], latency: float) -> None:
        if step % every == 0:
            print(
                f"step {step}: {distance:.2f} m to goal, v {command[0]:+.2f} m/s, "
                f"w {command[1]:+.2f} rad/s, loop {latency * 1e3:.1f} ms",
                file=sys.stderr, flush=True,
            )  # fmt: skip

    return show


def _print_summary(summary: dict[str, Any], as_json: bool, recorder: Any) -> None:
    if as_json:
        print(json_text(summary), flush=True)
        return
    print(
        f"{summary['robot']} {summary['method']}: {summary['outcome']} in {summary['time_s']:.1f} s, "
        f"TL {summary['tl_m']:.2f} m, PD {summary['pd_rad']:.2f} rad, min clearance "
        f"{summary['min_clearance_m']:.3f} m ({summary['steps']} steps); loop p50 "
        f"{summary['latency_p50_ms']} ms, p99 {summary['latency_p99_ms']} ms; "
        + ("robot stopped" if summary["stop_acknowledged"] else "stop NOT acknowledged"),
        flush=True,
    )
    if recorder is not None:
        print(f"wrote {recorder.path}", flush=True)
