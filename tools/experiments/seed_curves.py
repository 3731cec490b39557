"""Learning curves over training seeds: the greedy validation success of every seed of a run.

Reads ``eval/success_rate`` from each ``seed-<k>/metrics.jsonl`` of one or more training
runs over seeds (``d3dwa train --seeds 0-4 --out runs/NAME``) and draws one panel per run:
a thin line per seed, the mean over seeds thick, and a dot at the checkpoint the seed kept
(its config's rule: the best validation under ``keep: best``, the last under ``keep: final``;
from each seed's config.json and summary.json). The validation layouts are training material, so
these curves say how training went, not how a method does on the reported worlds.

    python -m tools.experiments.seed_curves runs/d3dwa runs/d3dwa-weights --out curves.png
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.io import atomic_savefig
from d3dwa_bullet.learning.training.logs import read_metrics
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.method_specs import method_label
from d3dwa_bullet.seed_dirs import kept_evaluation, seed_dirs
from tools.entry import ToolParser, tool_main
from tools.experiments.shipped_seeds import seed_decision_steps


def seed_curves(run: Path) -> dict[int, tuple[np.ndarray, np.ndarray, int | None]]:
    """Per seed of a run: (control steps, validation success, control step kept or None).

    A run that decides every ``decision_steps`` control steps counts its steps in decisions;
    they are scaled to control steps (0.1 s), the unit of the training budget, so runs of
    either kind share one axis.
    """
    curves = {}
    for k, path in seed_dirs(run).items():
        rows = read_metrics(path, "eval/success_rate")
        if not rows:
            continue
        summary = path / "summary.json"
        found = load_json(summary, ResultsError) if summary.is_file() else {}
        per = seed_decision_steps(path)
        _, kept = kept_evaluation(path, found)
        steps = np.array([r["step"] for r in rows]) * per
        values = np.array([r["value"] for r in rows])
        kept_step = kept.get("step")
        curves[k] = (steps, values, None if kept_step is None else int(kept_step) * per)
    return curves


def figure(runs: Sequence[Path], out: Path) -> Path:
    # start-up cost: matplotlib only here
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(3.6 * len(runs), 3.2), sharey=True)
    axes = [axes] if len(runs) == 1 else list(axes)
    for ax, run in zip(axes, runs, strict=True):
        curves = seed_curves(run)
        method = load_json(next(iter(seed_dirs(run).values())) / "config.json",
                           ResultsError)["method"] if curves else run.name  # fmt: skip
        for k, (steps, values, kept) in curves.items():
            ax.plot(steps / 1000, values, lw=0.8, alpha=0.6, label=f"seed {k}")
            if kept is not None and kept in steps:
                ax.plot(kept / 1000, values[list(steps).index(kept)], "o", ms=4, color="k")
        lengths = {len(s) for s, _, _ in curves.values()}
        if len(lengths) == 1 and curves:
            steps = next(iter(curves.values()))[0]
            mean = np.mean([v for _, v, _ in curves.values()], axis=0)
            ax.plot(steps / 1000, mean, lw=2.2, color="k", label="mean")
        ax.set_title(f"{method_label(method)} ({len(curves)} seeds)", fontsize=9)
        ax.set_xlabel("control steps (0.1 s) [k]")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("greedy validation success")
    axes[-1].legend(fontsize=6, loc="lower right")
    fig.suptitle("Validation success over training (dots: the checkpoint each seed kept)",
                 fontsize=9)  # fmt: skip
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_savefig(fig, out, dpi=130)
    plt.close(fig)
    return out


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="training runs over seeds (folders of seed-<k>/)")
    ap.add_argument("--out", required=True, help="PNG to write")
    args = ap.parse_args(argv)
    runs = [Path(r) for r in args.runs]
    empty = [str(r) for r in runs if not seed_curves(r)]
    if empty:
        print(f"seed_curves: error: {empty[0]}: no seed-<k>/metrics.jsonl with evaluations",
              file=sys.stderr)  # fmt: skip
        return 2
    print(f"figure: {figure(runs, Path(args.out))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
