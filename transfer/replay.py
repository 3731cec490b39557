"""Replay a recorded bag scan by scan through a step function: the observation pipeline
and, with ``transfer.sim_bridge.make_step_fn``, the estimator, policy and planner.

The step function's contract (``ScanStep`` in, ``StepOutput`` out, ``SkipScan`` to skip)
is in ``transfer.replay_step``; the rows, summary and figures in ``transfer.replay_output``.

Outputs in ``out_dir``: ``replay.csv`` (one row per replayed scan, flushed row by row into
``PARTIAL_CSV`` and moved over ``replay.csv`` when the run ends, complete or failed: an
earlier replay's file stays whole until then, and a killed run's rows are in the partial
file), ``summary.json`` (written
atomically; ``status`` is "running" until the run ends, then "complete" or "failed: ..."),
and figures ``path.png`` (path coloured by tau), ``sectors.png`` (sector ranges over time),
``commands.png`` (planner vs recorded command).
"""

from __future__ import annotations

import csv
import errno
import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import BagFormatError, WriteError
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from transfer.bag_reader import BagData, Clock, first_goal, read_bag
from transfer.replay_output import CSV_COLUMNS, ReplayResult, ReplayRow, csv_columns, plot_replay
from transfer.replay_step import ScanStep, SkipScan, StepFn, StepOutput, observe_only
from transfer.topics import TopicMap

__all__ = [
    "CSV_COLUMNS",
    "ReplayResult",
    "ScanStep",
    "SkipScan",
    "StepFn",
    "StepOutput",
    "observe_only",
    "replay_bag",
]

PARTIAL_CSV = ".replay.csv.partial"
"""Where replay.csv's rows are written while the replay runs."""
SKIP_BEFORE_ODOMETRY = "before first odometry sample"
SKIP_AFTER_ODOMETRY = "after last odometry sample"
SKIP_NO_VALID_BEAM = "all beams invalid"
#: A scan without a valid return is still replayed when at least this fraction of its beams
#: read +inf: REP-117 "no return within range", i.e. open space (every sector reads 1.0, as
#: in the simulator). Fewer, among NaN / 0 / -inf / out-of-range readings, is a broken scan.
MIN_NO_RETURN_FRACTION = 0.5


def _as_output(out: StepOutput | Mapping[str, Any], dim: int) -> StepOutput:
    if not isinstance(out, StepOutput):
        out = StepOutput(**dict(out))
    obs = np.asarray(out.observation, dtype=np.float64)
    if obs.shape != (dim,):
        raise ValueError(
            f"step function returned an observation of shape {obs.shape}, expected ({dim},)"
        )
    return out


def observation_names(step_fn: StepFn) -> tuple[str, ...]:
    """The observation entries a step function returns: its ``observation_layout``
    attribute (a progress-aware pipeline's), else the paper's 12."""
    return tuple(getattr(step_fn, "observation_layout", OBSERVATION_LAYOUT))


def _vec(value: Any, n: int) -> np.ndarray:
    if value is None:
        return np.full(n, np.nan)
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.size != n:
        raise ValueError(f"step function returned {arr.size} values where {n} were expected")
    return arr


def _informative(scan: LaserScan) -> bool:
    """True if the scan has a valid return, or is mostly +inf (open space)."""
    if scan.valid_mask().any():
        return True
    return np.isposinf(scan.ranges).mean() >= MIN_NO_RETURN_FRACTION


def _write_json(path: Path, data: dict[str, Any]) -> None:
    atomic_write_text(path, json.dumps(data, indent=2, allow_nan=True) + "\n")


def replay_bag(
    bag_path: str | Path,
    step_fn: StepFn = observe_only,
    goal: tuple[float, float] | np.ndarray | None = None,
    topics: TopicMap | None = None,
    mount: Pose2D | None = None,
    out_dir: str | Path | None = None,
    *,
    clock: Clock = "auto",
    max_command_gap: float = 0.25,
    plots: bool = True,
) -> ReplayResult:
    """Run every scan of a bag through ``step_fn``.

    goal: (x, y), m, in the odometry frame; default: the bag's first goal message.
    topics, mount, clock: see ``read_bag``. max_command_gap: a recorded command or planner
    parameter counts as "at" a scan if within this many seconds of it.
    Scans that cannot be replayed (corrupt, zero beams, no valid beam, outside the odometry
    span, or rejected by step_fn raising ``SkipScan``) are counted in ``skipped`` by reason.
    An exception from step_fn propagates after the rows so far are on disk and summary.json
    says "failed"; a bag that cannot be read at all leaves a "failed" summary.json too.
    """
    started = time.perf_counter()
    try:
        bag = read_bag(bag_path, topics=topics, mount=mount, clock=clock)
        if bag.odometry is None:
            raise BagFormatError(
                f"{bag.path}: no odometry: neither "
                f"{bag.topics['odometry'] or TopicMap().odometry!r} nor "
                f"{bag.topics['wheel_odometry'] or TopicMap().wheel_odometry!r} has a message"
            )
        if goal is not None:
            goal_xy = np.asarray(goal, dtype=np.float64).reshape(2)
            goal_source = "argument (odometry frame)"
        else:
            goal_xy, goal_source = first_goal(bag)
    except BagFormatError as err:
        if out_dir is not None:  # say why nothing was replayed, where the results would be
            Path(out_dir).mkdir(parents=True, exist_ok=True)
            status = {"bag": str(bag_path), "status": f"failed: {err}", "scans": 0, "replayed": 0}
            _write_json(Path(out_dir) / "summary.json", status)
        raise

    result = ReplayResult(
        bag=bag.path,
        rows=[],
        scans=bag.scan_messages,
        replayed=0,
        skipped={},
        topics=dict(bag.topics.topics),
        notes=list(bag.notes),
        clock=bag.clock,
        mount=bag.mount,
        mount_source=bag.mount_source,
        goal=(float(goal_xy[0]), float(goal_xy[1])),
        goal_source=goal_source,
        status="running",
    )
    for _, reason in bag.scan_rejects:
        result.skipped[reason] = result.skipped.get(reason, 0) + 1
    result.timing["read"] = time.perf_counter() - started

    out = Path(out_dir) if out_dir is not None else None
    writer = None
    handle = None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        result.files = {"csv": out / "replay.csv", "summary": out / "summary.json"}
        _write_json(result.files["summary"], result.summary())
        partial = out / PARTIAL_CSV  # an old replay.csv stays whole until this one ends
        if result.files["csv"].is_symlink():  # replaced at the end, never through a link
            raise WriteError(result.files["csv"], OSError(errno.ELOOP, "symbolic link"))
        try:  # never written through a link; moved over replay.csv when the replay ends
            flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW
            handle = os.fdopen(os.open(partial, flags, 0o666), "w", newline="")
        except OSError as err:
            raise WriteError(partial, err) from err
        writer = csv.writer(handle)
        writer.writerow(csv_columns(observation_names(step_fn)))
        handle.flush()
    started = time.perf_counter()
    try:
        _run(bag, step_fn, goal_xy, max_command_gap, result, writer, handle)
        result.timing["decide"] = time.perf_counter() - started
    except BaseException as err:
        result.status = f"failed: {type(err).__name__}: {err}"
        if handle is not None:
            _finish_csv(handle, result.files["csv"])
            _write_json(result.files["summary"], result.summary())
        raise
    if handle is not None:
        _finish_csv(handle, result.files["csv"])
    result.status = "complete"
    if out is not None:
        if plots and result.rows:
            result.files.update(plot_replay(result, out))
        _write_json(result.files["summary"], result.summary())
    return result


def _run(
    bag: BagData,
    step_fn: StepFn,
    goal: np.ndarray,
    max_command_gap: float,
    result: ReplayResult,
    writer: Any,
    handle: Any,
) -> None:
    assert bag.odometry is not None
    times = bag.scan_times_ns
    if times.size == 0:
        return
    poses, twists, where = bag.odometry.at(times)
    wheel = bag.wheel_odometry.at(times)[1] if bag.wheel_odometry is not None else None
    gyro = bag.imu.at(times) if bag.imu is not None else np.full(times.size, np.nan)
    gap = int(max_command_gap * 1e9)
    rec_cmd = bag.cmd_vel.nearest(times, gap) if bag.cmd_vel else np.full((times.size, 2), np.nan)
    rec_par = (
        bag.planner_params.nearest(times, gap)
        if bag.planner_params
        else np.full((times.size, 5), np.nan)
    )
    t0 = int(times[0])
    dim = len(observation_names(step_fn))
    skip_reason = {-1: SKIP_BEFORE_ODOMETRY, 1: SKIP_AFTER_ODOMETRY}
    for k, scan in enumerate(bag.scans):
        reason = skip_reason.get(int(where[k]))
        if reason is None and not _informative(scan):
            reason = SKIP_NO_VALID_BEAM
        if reason is not None:
            result.skipped[reason] = result.skipped.get(reason, 0) + 1
            continue
        step = ScanStep(
            t_ns=int(times[k]),
            scan=scan,
            mount=bag.mount,
            odom_pose=poses[k].copy(),
            odom_twist=twists[k].copy(),
            goal=goal.copy(),
            wheel_twist=None if wheel is None else wheel[k].copy(),
            imu_w=None if math.isnan(gyro[k]) else float(gyro[k]),
        )
        try:
            decided = _as_output(step_fn(step), dim)
        except SkipScan as skip:
            result.skipped[skip.reason] = result.skipped.get(skip.reason, 0) + 1
            continue
        row = ReplayRow(
            stamp_ns=int(times[k]),
            t=(int(times[k]) - t0) / 1e9,
            pose=_vec(decided.pose, 3),
            velocity=_vec(decided.velocity, 2),
            observation=np.asarray(decided.observation, dtype=np.float64),
            action=None if decided.action is None else int(decided.action),
            weights=_vec(decided.weights, 3),
            tau=math.nan if decided.tau is None else float(decided.tau),
            cmd=_vec(decided.cmd, 2),
            recorded_cmd=rec_cmd[k],
            recorded_params=rec_par[k],
        )
        result.rows.append(row)
        result.replayed += 1
        if writer is not None:
            writer.writerow(row.csv_values())
            handle.flush()
    if result.replayed == 0 and (where != 0).all():
        o = bag.odometry
        result.notes.append(
            f"no scan overlaps the odometry: scans span [{times[0]}, {times[-1]}] ns, "
            f"odometry [{o.t_ns[0]}, {o.t_ns[-1]}] ns on the {bag.clock} clock"
        )


def _finish_csv(handle: Any, target: Path) -> None:
    """Close the rows written so far and move them over ``target`` in one step."""
    handle.close()
    try:
        os.replace(target.parent / PARTIAL_CSV, target)
    except OSError as err:
        raise WriteError(target, err) from err
