"""The logs of a training run: episodes.csv, metrics.jsonl, TensorBoard events, the learning curve.

``MetricsLog`` appends one CSV row per episode (``EPISODE_FIELDS``) and TensorBoard-style
records ``{"step", "tag", "value"}`` (or ``"histogram"``) to metrics.jsonl; both are
append-only, so a resumed run truncates them to the sizes its checkpoint recorded
(``sizes``). ``read_episodes`` / ``read_metrics`` read them back, and ``learning_curve``
draws return and success rate against environment steps from them.

TensorBoard: every record also goes to event files in ``<out>/tb/`` (``tensorboard --logdir
<out>/tb``; a histogram as one scalar per bin, ``<tag>_count/<bin>``). ``tensorboard`` is a
dependency of the package, so ``d3dwa train`` writes them out of the box: it adds ~35 MB
beside torch's ~700 MB and 0.1 s to the start of a training run, and a log nobody has to ask
for is what a user of CleanRL or SB3 expects. A resumed run hides the events its crashed
predecessor wrote after the checkpoint (``purge_step``: the step after the last record left
in the truncated metrics.jsonl), so TensorBoard shows one curve, as metrics.jsonl does.
Should the import fail anyway (an install without dependencies, a broken protobuf), training
goes on: the first ``MetricsLog`` of the process says once, on stderr, that no event files
are written and that the scalars are in metrics.jsonl.
"""

from __future__ import annotations

import csv
import io
import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from d3dwa_bullet.errors import TrainingError
from d3dwa_bullet.io import AppendFile, atomic_savefig
from d3dwa_bullet.learning.training.run_dir import (
    EPISODES_FILE,
    LOG_FILES,
    METRICS_FILE,
    TENSORBOARD_DIR,
)
from d3dwa_bullet.loading import load_json_lines, parse_json

try:
    from torch.utils.tensorboard import SummaryWriter
except Exception as err:  # a dependency, but training must not stop without it (docstring)
    SummaryWriter = None  # type: ignore[assignment,misc]
    TENSORBOARD_ERROR = f"{type(err).__name__}: {err}"
else:
    TENSORBOARD_ERROR = ""
_notice_given = False

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
    """Appends episodes.csv and metrics.jsonl, and writes the same records as TensorBoard
    events to <out>/tb/ (unless ``tensorboard=False``; see the module docstring)."""

    def __init__(self, out: Path, tensorboard: bool = True) -> None:
        self.out = out
        path = out / EPISODES_FILE
        new = not path.exists()
        fieldnames = list(EPISODE_FIELDS)
        if not new:  # resuming: keep the file's own columns (a run from an older version)
            with path.open(newline="") as fh:
                fieldnames = next(csv.reader(fh), fieldnames)
        # each record whole or not at all, named on a full disk, never through a link
        self._episodes = AppendFile(path)
        self._fields = fieldnames
        if new:
            self.episode(dict(zip(fieldnames, fieldnames, strict=True)))
        purge_step = _step_after_last_record(out / METRICS_FILE)
        self._metrics = AppendFile(out / METRICS_FILE)
        self._tb = None
        if tensorboard and SummaryWriter is not None:
            self._tb = SummaryWriter(str(out / TENSORBOARD_DIR), purge_step=purge_step)
        elif tensorboard:
            _say_no_tensorboard(out)

    def scalar(self, step: int, tag: str, value: float) -> None:
        self._record({"step": step, "tag": tag, "value": float(value)})
        if self._tb is not None:
            self._tb.add_scalar(tag, value, step)

    def histogram(self, step: int, tag: str, counts: Mapping[str, int]) -> None:
        self._record({"step": step, "tag": tag, "histogram": dict(counts)})
        if self._tb is not None:
            for k, n in counts.items():
                self._tb.add_scalar(f"{tag}_count/{k}", n, step)

    def _record(self, record: Mapping[str, Any]) -> None:
        self._metrics.write((json.dumps(record) + "\n").encode())

    def episode(self, row: Mapping[str, Any]) -> None:
        buffer = io.StringIO(newline="")
        csv.DictWriter(buffer, fieldnames=self._fields, extrasaction="ignore").writerow(row)
        self._episodes.write(buffer.getvalue().encode("utf-8"))

    def flush(self) -> None:
        """TensorBoard's events to disk (the CSV and JSON records are written as they come)."""
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


def _step_after_last_record(path: Path) -> int | None:
    """One past the step of metrics.jsonl's last record (None if there is none): where a
    resumed run's TensorBoard events take over from those of the run before."""
    if not path.exists() or path.stat().st_size == 0:
        return None
    with path.open("rb") as fh:
        size = fh.seek(0, os.SEEK_END)
        tail = b""
        while size > 0 and tail.count(b"\n") < 2:  # read back until a whole last line
            block = min(size, 1 << 16)
            size -= block
            fh.seek(size)
            tail = fh.read(block) + tail
    lines = [line for line in tail.splitlines() if line.strip()]
    try:
        return int(parse_json(lines[-1], TrainingError, str(path))["step"]) + 1 if lines else None
    except (TrainingError, ValueError, KeyError, TypeError):  # not a record: purge nothing
        return None


def _say_no_tensorboard(out: Path) -> None:
    """The one-line notice, once per process, that no event files are written."""
    global _notice_given
    if _notice_given:
        return
    _notice_given = True
    print(
        f"d3dwa: TensorBoard is not available ({TENSORBOARD_ERROR}); no event files are "
        f"written, the scalars are in {out / METRICS_FILE}",
        file=sys.stderr,
    )


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
    rows = load_json_lines(path, TrainingError, "metrics log")
    return [r for r in rows if tag is None or r["tag"] == tag]


def _rolling(values: np.ndarray, window: int) -> np.ndarray:
    c = np.cumsum(np.insert(values.astype(np.float64), 0, 0.0))
    n = np.minimum(np.arange(1, len(values) + 1), window)
    return (c[1:] - c[np.arange(1, len(values) + 1) - n]) / n


def learning_curve(
    out: str | os.PathLike[str],
    path: str | os.PathLike[str],
    title: str = "",
    step_seconds: float = 0.1,
) -> Path:
    """Return and success rate vs env steps (training rolling means + greedy evaluations),
    and the greedy evaluations' value calibration: mean Q of the pairs they visited against
    the discounted return those pairs earned (docs/design/agent.md#value-calibration)."""
    rows = read_episodes(out)
    evals = read_metrics(out, "eval/success_rate")
    eval_returns = read_metrics(out, "eval/mean_return")
    eval_q = read_metrics(out, "eval/mean_q")
    eval_g = read_metrics(out, "eval/discounted_return")
    fig = Figure(figsize=(8, 8.5), tight_layout=True)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
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
                 label="greedy evaluation (eval_worlds)")  # fmt: skip
    if eval_q:
        ax3.plot([r["step"] for r in eval_q], [r["value"] for r in eval_q], "o-",
                 color="tab:purple", label="mean Q of the visited (s, a)")  # fmt: skip
    if eval_g:
        ax3.plot([r["step"] for r in eval_g], [r["value"] for r in eval_g], "s--",
                 color="tab:gray", label="discounted return they earned")  # fmt: skip
    ax1.set_ylabel("episodic return")
    ax2.set_ylabel("success rate")
    ax2.set_ylim(-0.05, 1.05)
    ax3.set_ylabel("greedy evaluation value")
    ax3.set_xlabel(f"environment steps ({step_seconds:g} s each)")
    for ax in (ax1, ax2, ax3):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower right", fontsize=8)
    ax1.set_title(title)
    return atomic_savefig(fig, path, dpi=90)
