"""The logs of a training run: episodes.csv, metrics.jsonl (and TensorBoard), the learning curve.

``MetricsLog`` appends one CSV row per episode (``EPISODE_FIELDS``) and TensorBoard-style
records ``{"step", "tag", "value"}`` (or ``"histogram"``) to metrics.jsonl; both are
append-only, so a resumed run truncates them to the sizes its checkpoint recorded
(``sizes``). ``read_episodes`` / ``read_metrics`` read them back, and ``learning_curve``
draws return and success rate against environment steps from them.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from d3dwa_bullet.io import atomic_savefig
from d3dwa_bullet.learning.training.run_dir import (
    EPISODES_FILE,
    LOG_FILES,
    METRICS_FILE,
    TENSORBOARD_DIR,
)

SUCCESS_WINDOW = 50
"""Episodes in the rolling training success rate and return."""
EPISODE_FIELDS = (
    "step",
    "episode",
    "task",
    "world",
    "noise",
    "outcome",
    "return",
    "length",
    "epsilon",
    "tau_mean",
    "fallbacks",
    "wall_time",
    "route_start",
)


class MetricsLog:
    """Appends episodes.csv and metrics.jsonl (and TensorBoard events if available)."""

    def __init__(self, out: Path, tensorboard: bool = True) -> None:
        self.out = out
        path = out / EPISODES_FILE
        new = not path.exists()
        fieldnames = list(EPISODE_FIELDS)
        if not new:  # resuming: keep the file's own columns (a run from an older version)
            with path.open(newline="") as fh:
                fieldnames = next(csv.reader(fh), fieldnames)
        self._episodes = path.open("a", newline="")
        self._writer = csv.DictWriter(self._episodes, fieldnames=fieldnames, extrasaction="ignore")
        if new:
            self._writer.writeheader()
        self._metrics = (out / METRICS_FILE).open("a")
        self._tb = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter  # optional dependency

                self._tb = SummaryWriter(str(out / TENSORBOARD_DIR))
            except Exception:  # optional: tensorboard not installed
                self._tb = None

    def scalar(self, step: int, tag: str, value: float) -> None:
        self._metrics.write(json.dumps({"step": step, "tag": tag, "value": float(value)}) + "\n")
        if self._tb is not None:
            self._tb.add_scalar(tag, value, step)

    def histogram(self, step: int, tag: str, counts: Mapping[str, int]) -> None:
        self._metrics.write(
            json.dumps({"step": step, "tag": tag, "histogram": dict(counts)}) + "\n"
        )
        if self._tb is not None:
            for k, n in counts.items():
                self._tb.add_scalar(f"{tag}_count/{k}", n, step)

    def episode(self, row: Mapping[str, Any]) -> None:
        self._writer.writerow(row)

    def flush(self) -> None:
        self._episodes.flush()
        self._metrics.flush()
        if self._tb is not None:
            self._tb.flush()

    def sizes(self) -> dict[str, int]:
        self.flush()
        return {name: (self.out / name).stat().st_size for name in LOG_FILES}

    def close(self) -> None:
        self.flush()
        self._episodes.close()
        self._metrics.close()
        if self._tb is not None:
            self._tb.close()


def read_episodes(out: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Rows of <out>/episodes.csv with numbers parsed."""
    path = Path(out) / EPISODES_FILE
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("step", "episode", "length", "fallbacks"):
            r[k] = int(r[k])
        for k in ("return", "epsilon", "tau_mean", "wall_time"):
            r[k] = float(r[k])
        if "route_start" in r:
            r["route_start"] = r["route_start"] == "True"
    return rows


def read_metrics(out: str | os.PathLike[str], tag: str | None = None) -> list[dict[str, Any]]:
    """Records of <out>/metrics.jsonl, optionally only one tag."""
    path = Path(out) / METRICS_FILE
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [r for r in rows if tag is None or r["tag"] == tag]


def _rolling(values: np.ndarray, window: int) -> np.ndarray:
    c = np.cumsum(np.insert(values.astype(np.float64), 0, 0.0))
    n = np.minimum(np.arange(1, len(values) + 1), window)
    return (c[1:] - c[np.arange(1, len(values) + 1) - n]) / n


def learning_curve(
    out: str | os.PathLike[str], path: str | os.PathLike[str], title: str = ""
) -> Path:
    """Return and success rate vs env steps (training rolling means + greedy evaluations)."""
    rows = read_episodes(out)
    evals = read_metrics(out, "eval/success_rate")
    eval_returns = read_metrics(out, "eval/mean_return")
    fig = Figure(figsize=(8, 6), tight_layout=True)
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    if rows:
        steps = np.array([r["step"] for r in rows])
        returns = np.array([r["return"] for r in rows])
        success = np.array([r["outcome"] == "goal" for r in rows], dtype=float)
        ax1.plot(steps, returns, ".", ms=2, alpha=0.3, color="tab:blue", label="episode")
        ax1.plot(steps, _rolling(returns, SUCCESS_WINDOW), color="tab:blue",
                 label=f"mean of last {SUCCESS_WINDOW}")  # fmt: skip
        ax2.plot(steps, _rolling(success, SUCCESS_WINDOW), color="tab:green",
                 label=f"training (last {SUCCESS_WINDOW} episodes)")  # fmt: skip
    if eval_returns:
        ax1.plot([r["step"] for r in eval_returns], [r["value"] for r in eval_returns], "o-",
                 color="tab:red", label="greedy evaluation")  # fmt: skip
    if evals:
        ax2.plot([r["step"] for r in evals], [r["value"] for r in evals], "o-", color="tab:red",
                 label="greedy evaluation (training worlds)")  # fmt: skip
    ax1.set_ylabel("episodic return")
    ax2.set_ylabel("success rate")
    ax2.set_ylim(-0.05, 1.05)
    ax2.set_xlabel("environment steps (0.1 s each)")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower right", fontsize=8)
    ax1.set_title(title)
    return atomic_savefig(fig, path, dpi=90)
