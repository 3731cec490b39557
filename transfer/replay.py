"""Replay a recorded bag scan by scan through the observation pipeline (and, when wired, the
estimator, policy and planner).

All per-scan processing goes through ONE injectable step function::

    step_fn(step: ScanStep) -> StepOutput | Mapping[str, Any]

``observe_only`` (the default) builds the 12-d observation from the recorded odometry; the
full pipeline (``d3dwa_bullet.transfer_bridge.make_step_fn``) takes the recorded odometry
(or re-fuses wheel odometry and gyro) as the estimate, asks the policy for an action and
the planner for a command, with the simulator's own code. A step function may raise
``SkipScan(reason)`` to skip a scan it cannot use; it is counted like the reader's skips.

Outputs in ``out_dir``: ``replay.csv`` (one row per replayed scan, flushed row by row, so a
run that fails or is killed keeps every completed row), ``summary.json`` (written
atomically; ``status`` is "running" until the run ends, then "complete" or "failed: ..."),
and figures ``path.png`` (path coloured by tau), ``sectors.png`` (sector ranges over time),
``commands.png`` (planner vs recorded command).
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT, build_observation
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body
from transfer.bag_reader import BagData, Clock, first_goal, read_bag
from transfer.topics import TopicMap

SKIP_BEFORE_ODOMETRY = "before first odometry sample"
SKIP_AFTER_ODOMETRY = "after last odometry sample"
SKIP_NO_VALID_BEAM = "all beams invalid"
#: A scan without a valid return is still replayed when at least this fraction of its beams
#: read +inf: REP-117 "no return within range", i.e. open space (every sector reads 1.0, as
#: in the simulator). Fewer, among NaN / 0 / -inf / out-of-range readings, is a broken scan.
MIN_NO_RETURN_FRACTION = 0.5

CSV_COLUMNS = (
    ("stamp_ns", "t", "x", "y", "yaw", "v", "w")
    + tuple(f"obs_{name}" for name in OBSERVATION_LAYOUT)
    + ("action", "wp", "wc", "ws", "tau", "cmd_v", "cmd_w")
    + ("rec_cmd_v", "rec_cmd_w", "rec_wp", "rec_wc", "rec_ws", "rec_tau", "rec_action")
)


@dataclass(frozen=True)
class ScanStep:
    """What is known at one scan time; the step function's only input.

    t_ns: replay-clock time, int ns. odom_pose: (3,) [x m, y m, yaw rad] and odom_twist:
    (2,) [v m/s, w rad/s] from the bag's odometry interpolated to t_ns; wheel_twist the same
    from wheel odometry (None if absent); imu_w: gyro yaw rate, rad/s (None if no IMU sample
    brackets t_ns); goal: (2,) m, odometry frame; mount: lidar pose in base_link.
    """

    t_ns: int
    scan: LaserScan
    mount: Pose2D
    odom_pose: np.ndarray
    odom_twist: np.ndarray
    goal: np.ndarray
    wheel_twist: np.ndarray | None = None
    imu_w: float | None = None

    def points(self) -> np.ndarray:
        """Valid returns in base_link: (M, 2) float64, m."""
        return scan_points_body(self.scan, self.mount)


@dataclass(frozen=True)
class StepOutput:
    """What the step function decided at one scan.

    observation: (12,) float64; pose: (3,) estimated [x, y, yaw]; velocity: (2,) estimated
    [v, w]; action: index into the action set; weights: (wp, wc, ws); tau: horizon, s;
    cmd: planner command (v m/s, w rad/s). Unused fields stay None.
    """

    observation: np.ndarray
    pose: tuple[float, float, float] | np.ndarray
    velocity: tuple[float, float] | np.ndarray
    action: int | None = None
    weights: tuple[float, float, float] | None = None
    tau: float | None = None
    cmd: tuple[float, float] | None = None


StepFn = Callable[[ScanStep], StepOutput | Mapping[str, Any]]


class SkipScan(Exception):
    """Raised by a step function to skip one scan; counted in ``skipped`` under ``reason``."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def observe_only(step: ScanStep) -> StepOutput:
    """Default step: the observation from the recorded odometry, no decision."""
    obs = build_observation(step.odom_pose, step.odom_twist, step.goal, step.points())
    return StepOutput(observation=obs, pose=step.odom_pose, velocity=step.odom_twist)


@dataclass(frozen=True)
class ReplayRow:
    """One replayed scan. NaN marks a value the step function or the bag did not provide."""

    stamp_ns: int
    t: float
    """Seconds since the bag's first readable scan (replay clock)."""
    pose: np.ndarray
    velocity: np.ndarray
    observation: np.ndarray
    action: int | None
    weights: np.ndarray
    tau: float
    cmd: np.ndarray
    recorded_cmd: np.ndarray
    """(2,) nearest recorded command, NaN if none within the tolerance."""
    recorded_params: np.ndarray
    """(5,) nearest recorded [wp, wc, ws, tau, action_index], NaN if none."""

    def csv_values(self) -> list[str]:
        def fmt(x: float) -> str:
            return "" if math.isnan(x) else repr(float(x))

        nums = [*self.pose, *self.velocity, *self.observation]
        tail = [*self.weights, self.tau, *self.cmd, *self.recorded_cmd, *self.recorded_params]
        return (
            [str(self.stamp_ns), repr(self.t)]
            + [fmt(x) for x in nums]
            + ["" if self.action is None else str(self.action)]
            + [fmt(x) for x in tail]
        )


@dataclass
class ReplayResult:
    """Outcome of ``replay_bag``: per-scan rows, counts, and how the bag was interpreted."""

    bag: Path
    rows: list[ReplayRow]
    scans: int
    """Messages on the scan topic (replayed + skipped)."""
    replayed: int
    skipped: dict[str, int]
    """Reason -> number of scans skipped for it."""
    topics: dict[str, str | None]
    notes: list[str]
    clock: str
    mount: Pose2D
    mount_source: str
    goal: tuple[float, float]
    goal_source: str
    files: dict[str, Path] = field(default_factory=dict)
    status: str = "complete"
    timing: dict[str, float] = field(default_factory=dict)
    """Wall seconds: "read" (open the bag, decode every message, assemble the series) and
    "decide" (observation, estimator, policy, planner and CSV row for every scan)."""

    def column(self, name: str) -> np.ndarray:
        """One CSV column over all rows as float64 (missing values are NaN)."""
        k = CSV_COLUMNS.index(name)
        return np.array([float(r.csv_values()[k] or "nan") for r in self.rows])

    def summary(self) -> dict[str, Any]:
        """Everything but the rows, JSON-serialisable."""
        return {
            "bag": str(self.bag),
            "status": self.status,
            "scans": self.scans,
            "replayed": self.replayed,
            "skipped": dict(self.skipped),
            "topics": dict(self.topics),
            "clock": self.clock,
            "mount": {"x": self.mount.x, "y": self.mount.y, "yaw": self.mount.yaw},
            "mount_source": self.mount_source,
            "goal": list(self.goal),
            "goal_source": self.goal_source,
            "notes": list(self.notes),
            "files": {k: str(v) for k, v in self.files.items()},
            "timing_s": {k: round(v, 4) for k, v in self.timing.items()},
        }


def _as_output(out: StepOutput | Mapping[str, Any]) -> StepOutput:
    if not isinstance(out, StepOutput):
        out = StepOutput(**dict(out))
    obs = np.asarray(out.observation, dtype=np.float64)
    if obs.shape != (len(OBSERVATION_LAYOUT),):
        raise ValueError(
            f"step function returned an observation of shape {obs.shape}, expected (12,)"
        )
    return out


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
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    os.replace(tmp, path)


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
        handle = result.files["csv"].open("w", newline="")
        writer = csv.writer(handle)
        writer.writerow(CSV_COLUMNS)
        handle.flush()
    started = time.perf_counter()
    try:
        _run(bag, step_fn, goal_xy, max_command_gap, result, writer, handle)
        result.timing["decide"] = time.perf_counter() - started
    except BaseException as err:
        result.status = f"failed: {type(err).__name__}: {err}"
        if handle is not None:
            handle.close()
            _write_json(result.files["summary"], result.summary())
        raise
    if handle is not None:
        handle.close()
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
            decided = _as_output(step_fn(step))
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


def plot_replay(result: ReplayResult, out_dir: Path) -> dict[str, Path]:
    """Write path.png, sectors.png and commands.png; returns name -> path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = np.array([r.t for r in result.rows])
    pose = np.array([r.pose for r in result.rows])
    tau = np.array([r.tau for r in result.rows])
    obs = np.array([r.observation for r in result.rows])
    cmd = np.array([r.cmd for r in result.rows])
    rec = np.array([r.recorded_cmd for r in result.rows])
    files: dict[str, Path] = {}

    def save(fig: Figure, name: str) -> None:
        FigureCanvasAgg(fig)
        files[name] = out_dir / f"{name}.png"
        fig.savefig(files[name], dpi=100)

    fig = Figure(figsize=(5, 5), layout="constrained")
    ax = fig.add_subplot()
    by_tau = not np.isnan(tau).all()
    sc = ax.scatter(pose[:, 0], pose[:, 1], c=tau if by_tau else t, s=8, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="tau [s]" if by_tau else "t [s]")
    ax.plot(*result.goal, marker="*", color="red", markersize=12, linestyle="none", label="goal")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{result.bag.name}: estimated path")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best")
    save(fig, "path")

    fig = Figure(figsize=(8, 3), layout="constrained")
    ax = fig.add_subplot()
    sectors = obs[:, 4:]
    im = ax.imshow(
        sectors.T,
        aspect="auto",
        origin="lower",
        extent=(t[0], t[-1] if t[-1] > t[0] else t[0] + 1e-3, -0.5, sectors.shape[1] - 0.5),
        vmin=0.0,
        vmax=1.0,
        cmap="magma",
        interpolation="nearest",
    )
    fig.colorbar(im, ax=ax, label="range / d_max")
    ax.set(xlabel="t [s]", ylabel="sector (0 = right)", title="observation sectors")
    save(fig, "sectors")

    fig = Figure(figsize=(8, 4), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    for i, (ax, label) in enumerate(zip(axes, ("v [m/s]", "w [rad/s]"), strict=True)):
        ax.plot(t, cmd[:, i], label="planner")
        ax.plot(t, rec[:, i], label="recorded", linestyle="--")
        ax.set_ylabel(label)
    axes[0].legend(loc="best")
    axes[1].set_xlabel("t [s]")
    save(fig, "commands")
    return files
