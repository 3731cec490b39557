"""Failure modes of a sweep (or eval) directory: how each method fails under each noise.

Reads results.csv and every episode's per-step log, classifies each failure with
:mod:`d3dwa_bullet.evaluation.failures` (primary mode and symptoms), and prints one row per
(noise, method): episodes, failures, the count of each primary mode, how many failures
show each symptom at all, and how many successful episodes show it too (a symptom as
common among successes does not explain the failures), and the failures that turned circles
(``circling``: a count beside the modes, see failures.CIRCLING_RAD_S). ``--figure PNG`` draws the primary modes as stacked bars per
noise profile; ``--json`` prints the records.

Every row needs its log. A directory that took episodes with ``--reuse`` keeps no log of them
(nor does a results folder committed without ``logs/``): the tool then names the first missing
log and how many are missing, and ``--logged-only`` classifies the episodes that have one,
saying how many of each (noise, method) were left out (``unlogged`` in the records).

    python -m tools.experiments.failure_modes /work/results/profiles-seeds --figure modes.png
"""

from __future__ import annotations

import json
import sys
from collections import Counter, defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.failures import MODES, SYMPTOMS, circling, classify, recoveries
from d3dwa_bullet.evaluation.jobs import row_log, row_log_path
from d3dwa_bullet.evaluation.results import job_rows, recovery_of
from d3dwa_bullet.evaluation.sweep_settings import PROFILES
from d3dwa_bullet.io import atomic_savefig
from d3dwa_bullet.method_specs import method_label
from tools.entry import ToolParser, tool_main


def failure_records(out: Path, logged_only: bool = False) -> list[dict[str, Any]]:
    """One record per (noise, method): episodes, failures, modes, symptoms. An episode without
    its log is refused (ResultsError: the first such log and how many), or with
    ``logged_only`` left out and counted in ``unlogged``; a (noise, method) with no logged
    episode then has no record, and a directory with none at all is refused."""
    if not (out / "results.csv").is_file():
        raise ResultsError(f"{out}: no results.csv")
    rows = job_rows(out)
    logged: list[dict[str, Any]] = []
    unlogged: list[dict[str, Any]] = []
    for r in rows:
        (logged if row_log_path(out, r).is_file() else unlogged).append(r)
    if unlogged and (not logged_only or not logged):
        first = row_log_path(out, unlogged[0])
        hint = "" if logged_only else "; --logged-only classifies the episodes that have one"
        raise ResultsError(
            f"{first}: log of the episode is missing ({len(unlogged)} of {len(rows)} episodes"
            f" have none{hint})"
        )
    left: Counter[tuple[str, str]] = Counter((r["noise"], r["method"]) for r in unlogged)
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in logged:
        groups[(r["noise"], r["method"])].append(r)
    records = []
    for (noise, method), rs in groups.items():
        modes: Counter[str] = Counter()
        seen: Counter[str] = Counter()
        in_goals: Counter[str] = Counter()
        started = progressed = circles = 0
        for r in rs:
            log = row_log(out, r)
            found = classify(log)
            n, good = recoveries(log)
            started, progressed = started + n, progressed + good
            if r["outcome"] == "goal":
                in_goals.update(found["symptoms"])
                continue
            modes[found["mode"]] += 1
            seen.update(found["symptoms"])
            circles += circling(float(r["pd_rad"]), float(r["time_s"]))
        failures = sum(modes.values())
        records.append({
            "noise": noise, "method": method, "episodes": len(rs), "failures": failures,
            "modes": {m: modes[m] for m in MODES}, "symptoms": {s: seen[s] for s in SYMPTOMS},
            # the same symptoms among the successes: a symptom as common there explains nothing
            "symptoms_in_goals": {s: in_goals[s] for s in SYMPTOMS},
            # recoveries started, and those after which the robot moved on (failures.py)
            "recoveries": started, "recoveries_with_progress": progressed,
            # failures whose heading turned > 1 rad/s on average, whatever their mode
            "circling": circles,
            # episodes of this (noise, method) without a log, left out (--logged-only)
            "unlogged": left[(noise, method)],
        })  # fmt: skip
    return records


def markdown(records: Sequence[dict[str, Any]], noises: Sequence[str]) -> str:
    lines = [
        "| noise | method | episodes | failures | "
        + " | ".join(MODES)
        + " | "
        + " | ".join(f"any {s}" for s in SYMPTOMS)
        + " | "
        + " | ".join(f"{s} in goals" for s in SYMPTOMS)
        + " | recoveries | recoveries with progress | circling failures |",
        "|---|---|" + "---:|" * (5 + len(MODES) + 2 * len(SYMPTOMS)),
    ]
    for noise in noises:
        for r in (r for r in records if r["noise"] == noise):
            cells = [str(r["episodes"]), str(r["failures"])]
            cells += [str(r["modes"][m] or "") for m in MODES]
            cells += [str(r["symptoms"][s] or "") for s in SYMPTOMS]
            goals = r["episodes"] - r["failures"]
            cells += [f"{r['symptoms_in_goals'][s]}/{goals}" if goals else "" for s in SYMPTOMS]
            cells += [str(r["recoveries"]), str(r["recoveries_with_progress"])]
            cells += [str(r["circling"] or "")]
            label = method_label(r["method"])
            lines.append(f"| {noise} | {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def figure(
    records: Sequence[dict[str, Any]], noises: Sequence[str], path: Path, note: str = ""
) -> Path:
    # start-up cost: matplotlib only when a figure is asked for
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(dict.fromkeys(r["method"] for r in records))
    fig, axes = plt.subplots(1, len(noises), figsize=(3.2 * len(noises), 4.6), sharey=True)
    axes = [axes] if len(noises) == 1 else list(axes)
    colours = [plt.get_cmap("tab10")(i) for i in range(10)]
    for ax, noise in zip(axes, noises, strict=True):
        by_method = {r["method"]: r for r in records if r["noise"] == noise}
        bottoms = [0.0] * len(methods)
        for i, mode in enumerate(MODES):
            share = [
                100 * by_method[m]["modes"][mode] / by_method[m]["episodes"]
                if m in by_method else 0.0
                for m in methods
            ]  # fmt: skip
            ax.bar(range(len(methods)), share, bottom=bottoms, color=colours[i],
                   label=mode if ax is axes[0] else None)  # fmt: skip
            bottoms = [b + s for b, s in zip(bottoms, share, strict=True)]
        ax.set_title(f"noise: {noise}")
        ax.set_xticks(range(len(methods)))
        ax.set_xticklabels([method_label(m) for m in methods], rotation=60, ha="right",
                           fontsize=7)  # fmt: skip
    axes[0].set_ylabel("failed episodes [%],\nby primary mode" + note)
    fig.legend(loc="upper center", ncol=len(MODES), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_savefig(fig, path, dpi=130)
    plt.close(fig)
    return path


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="a results directory of `d3dwa sweep` or `d3dwa eval`")
    ap.add_argument("--figure", help="write the stacked-bar figure to this PNG")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--logged-only", action="store_true",
                    help="classify the episodes that have a per-step log, count the rest")  # fmt: skip
    args = ap.parse_args(argv)
    records = failure_records(Path(args.dir), args.logged_only)
    found = list(dict.fromkeys(r["noise"] for r in records))
    noises = sorted(found, key=lambda n: PROFILES.index(n) if n in PROFILES else len(PROFILES))
    recovery = recovery_of(Path(args.dir))
    note = "" if recovery == "none" else f"\nwith recovery layer {recovery}"
    if args.figure:
        figure(records, noises, Path(args.figure), note)
    if args.json:
        print(json.dumps(records, indent=1))
    else:
        if recovery != "none":
            print(f"Recovery layer: {recovery}\n")
        print(markdown(records, noises), end="")
        if args.logged_only:  # every row not in a record's episodes had no log
            left = len(job_rows(Path(args.dir))) - sum(r["episodes"] for r in records)
            print(
                f"\nLeft out, without a per-step log: {left} episode{'s' * (left != 1)} (in no row above)."
            )
        if args.figure:
            print(f"figure: {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
