"""What a replay produces: one row per replayed scan, the run's summary, and its figures.

``replay.csv`` has the columns ``CSV_COLUMNS`` (one ``ReplayRow`` each; ``csv_columns`` of
the observation layout the step function reads, when it is not the paper's); ``summary.json``
is ``ReplayResult.summary()``; the figures are ``path.png`` (path coloured by tau),
``sectors.png`` (sector ranges over time) and ``commands.png`` (planner vs recorded command).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.sim.scan import Pose2D


def csv_columns(layout: tuple[str, ...] = OBSERVATION_LAYOUT) -> tuple[str, ...]:
    """The replay.csv header for an observation of entries ``layout``."""
    return (
        ("stamp_ns", "t", "x", "y", "yaw", "v", "w")
        + tuple(f"obs_{name}" for name in layout)
        + ("action", "wp", "wc", "ws", "tau", "cmd_v", "cmd_w")
        + ("rec_cmd_v", "rec_cmd_w", "rec_wp", "rec_wc", "rec_ws", "rec_tau", "rec_action")
    )


CSV_COLUMNS = csv_columns()


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


def plot_replay(result: ReplayResult, out_dir: Path) -> dict[str, Path]:
    """Write path.png, sectors.png and commands.png; returns name -> path."""
    # matplotlib takes ~0.3 s to import; only a replay that draws its figures pays for it.
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
    sectors = obs[:, 4 : len(OBSERVATION_LAYOUT)]  # a progress observation appends more
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
