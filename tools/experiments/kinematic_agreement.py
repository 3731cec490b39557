"""Read the kinematic-agreement study (docs/pilots/kinematic-agreement/README.md).

    python -m tools.experiments.kinematic_agreement runs/kinematic-agreement \\
        --page docs/pilots/kinematic-agreement

For each family (r-style, barn) and recovery layer (none, nav2) the study holds two sweep
directories, ``<family>-<recovery>-kinematic`` and ``<family>-<recovery>-pybullet``. Each method
on the kinematic side is read against the same method on PyBullet's with ``d3dwa compare KIN
--methods M,M --against PB --json`` (the testbed's readings: paired by layout, TOST against the
default margins, robot score +-0.03 and success +-3 points), per profile (its ``all layouts
(PROFILE)`` group). With ``--page`` the readings table goes to ``readings.md`` there, each
directory's results.csv and meta.json to ``rows/<dir>/``, and one figure per pair whose outcomes
differ to ``figures/`` (both trajectories side by side, from the runs' logs). A missing
directory or method is a row saying so, not an error: a run cut short still reads.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import shutil
from collections.abc import Sequence
from pathlib import Path

from scipy import stats

from d3dwa_bullet.cli.app import main as d3dwa
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.jobs import row_log_path
from d3dwa_bullet.evaluation.plotting import trajectory_figure
from d3dwa_bullet.evaluation.readings import reading_text
from d3dwa_bullet.evaluation.results import load_log, read_results
from d3dwa_bullet.io import file_stem
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main

FAMILIES = ("r-style", "barn")
RECOVERIES = ("none", "nav2")
METHODS = ("dwa3", "d3dwa")
PROFILES = ("none", "real", "harsh")
METRICS = (("success", "success"), ("score", "robot score"))


def compare(kin: Path, ref: Path, method: str) -> dict | None:
    """d3dwa compare's JSON record of method on kin against method on ref (None if refused)."""
    buffer, errors = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(errors):
        code = d3dwa(
            [
                "compare",
                str(kin),
                "--methods",
                f"{method},{method}",
                "--against",
                str(ref),
                "--json",
            ]
        )
    return (
        parse_json(buffer.getvalue(), ResultsError, "d3dwa compare --json") if code == 0 else None
    )


def cell_text(record: dict | None, profile: str, metric: str) -> str:
    """'reading (mean difference [interval], n layouts)' of one profile's group and metric."""
    if record is None:
        return "not run"
    group = next((g for g in record["groups"] if g["group"] == f"all layouts ({profile})"), None)
    if group is None or metric not in group.get("readings", {}):
        return "no pairs"
    r = group["readings"][metric]
    if r.get("reading") is None:
        return reading_text(r)
    if r.get("difference") is None:
        return f"{reading_text(r)}, n={r['layouts']}"
    scale, unit = (100.0, " pt") if metric == "success" else (1.0, "")
    interval = (
        "" if r.get("low") is None else f" [{scale * r['low']:+.3g}, {scale * r['high']:+.3g}]"
    )
    return f"{reading_text(r)}: {scale * r['difference']:+.3g}{unit}{interval}, n={r['layouts']}"


def disagreements(kin: Path, ref: Path) -> list[tuple[dict, dict]]:
    """(kinematic row, PyBullet row) of each episode whose outcomes differ."""
    key = ("world", "method", "seed", "noise")
    theirs = {tuple(r[k] for k in key): r for r in read_results(ref)}
    return [(r, theirs[k]) for r in read_results(kin) if (k := tuple(r[c] for c in key)) in theirs
            and theirs[k]["outcome"] != r["outcome"]]  # fmt: skip


def figure(kin: Path, ref: Path, pair: tuple[dict, dict], path: Path) -> None:
    """Both trajectories of one episode, kinematic left, PyBullet right."""
    runs = []
    for out, row, label in ((kin, pair[0], "kinematic"), (ref, pair[1], "PyBullet")):
        log = load_log(row_log_path(out, row))
        t = list(log["t"]) + [row["time_s"]]
        runs.append({"label": f"{row['method']} {row['noise']} {label}", "outcome": row["outcome"], "t": t,
                     "x": log["true_x"], "y": log["true_y"], "tau": list(log["tau"]) + list(log["tau"][-1:]),
                     "recovery": log.get("recovery")})  # fmt: skip
    world = load_world(pair[0]["world"])
    trajectory_figure(
        world, runs, path, title=f"{world.name}: {pair[0]['method']}, {pair[0]['noise']}"
    )


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", help="the study's runs directory (runs/kinematic-agreement)")
    ap.add_argument("--page", help="write readings.md, rows/ and figures/ into this directory")
    args = ap.parse_args(argv)
    runs = Path(args.runs)
    if not runs.is_dir():
        ap.error(f"{runs}: not a directory")
    lines = [
        "Each cell: family, recovery layer, method, profile; then the readings of kinematic - PyBullet.",
        "",
    ]
    differ: list[tuple[Path, Path, tuple[dict, dict]]] = []
    counts = []
    for family in FAMILIES:
        for recovery in RECOVERIES:
            kin, ref = (runs / f"{family}-{recovery}-{b}" for b in ("kinematic", "pybullet"))
            both = (kin / "results.csv").exists() and (ref / "results.csv").exists()
            for method in METHODS:
                record = compare(kin, ref, method) if both else None
                for profile in PROFILES:
                    cells = [cell_text(record, profile, m) for m, _ in METRICS]
                    lines += [f"- {family}, layer {recovery}, {method}, {profile}:", f"  success {cells[0]};",
                              f"  robot score {cells[1]}"]  # fmt: skip
            if both:
                pairs = disagreements(kin, ref)
                differ += [(kin, ref, p) for p in pairs]
                shared = {(r["world"], r["method"], r["noise"]) for r in read_results(ref)}
                kin_goal = sum(k["outcome"] == "goal" for k, _ in pairs)
                ref_goal = sum(r["outcome"] == "goal" for _, r in pairs)
                bound = stats.binomtest(len(pairs), len(shared)).proportion_ci(0.95).high
                counts += [
                    f"- {family}, recovery {recovery}: {len(shared)} pairs, {len(pairs)} with different outcomes",
                    f"  (the goal on the kinematic side only: {kin_goal}, on PyBullet's only: {ref_goal});",
                    f"  their rate at most {100 * bound:.0f} % (95 %, Clopper-Pearson)",
                ]
    text = "\n".join(lines + ["", *counts]) + "\n"
    print(text)
    if not args.page:
        return
    page = Path(args.page)
    (page / "readings.md").write_text(
        "# Readings (tools/experiments/kinematic_agreement.py)\n\n" + text
    )
    for d in sorted(runs.iterdir()):
        if (d / "results.csv").exists():
            (page / "rows" / d.name).mkdir(parents=True, exist_ok=True)
            for name in ("results.csv", "meta.json"):
                shutil.copyfile(d / name, page / "rows" / d.name / name)
    (page / "figures").mkdir(exist_ok=True)
    for kin, ref, pair in differ:
        row = pair[0]
        name = file_stem(
            f"{kin.name.removesuffix('-kinematic')}__{row['world']}__{row['method']}__{row['noise']}"
        )
        figure(kin, ref, pair, page / "figures" / f"{name}.png")
    print(f"page: {page / 'readings.md'}; {len(differ)} figures in {page / 'figures'}")


if __name__ == "__main__":
    raise SystemExit(main())
