"""Read the kinematic-agreement study (docs/pilots/kinematic-agreement/README.md).

    python -m tools.experiments.kinematic_agreement runs/kinematic-agreement-2 \\
        --page docs/pilots/kinematic-agreement

For each family (r-style, barn-style) and recovery layer (nav2 under the profiles none, real and
harsh; none under the profile none) the study holds two sweep directories,
``<family>-<layer>-kinematic`` and ``<family>-<layer>-pybullet``. Each method on the kinematic side
is read against the same method on PyBullet's with ``d3dwa compare KIN --methods M,M --against PB
--json`` (the testbed's readings: paired by layout over the layouts both sides ran, TOST against
the default margins, robot score +-0.03 and success +-3 points), per profile (its ``all layouts
noise PROFILE`` group). A cell where both metrics read equivalent within the margin (TOST rejects,
whether or not a difference inside it also reads) is one the backend may answer; any other is
PyBullet's, with the layouts the repository's sizing says would decide it when it is inconclusive.

Beside the readings, every pair of episodes is measured where the two runs part
(:mod:`tools.experiments.agreement_paths`). With ``--page`` the readings go to ``readings.md``
there, each directory's results.csv and meta.json to ``rows/<dir>/``, and the first
``--figures`` pairs whose outcomes differ, in row order, of each family and layer to
``figures/`` (both trajectories side by side, from the runs' logs). A missing directory or
method is a row saying so, not an error: a run cut short still reads.
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
from d3dwa_bullet.evaluation.results import read_results
from d3dwa_bullet.io import file_stem
from d3dwa_bullet.loading import parse_json
from tools.entry import ToolParser, tool_main
from tools.experiments.agreement_paths import figure, parting_lines

FAMILIES = ("r-style", "barn-style")
CONDITIONS = (("nav2", ("none", "real", "harsh")), ("none", ("none",)))
"""(recovery layer, profiles): the layer under every profile, the paper's stack under none."""
METHODS = ("dwa3", "d3dwa", "d3dwa-weights", "d3dwa-dr", "random@10")
METRICS = ("success", "score")
FIGURES = 2
"""Figures of differing pairs per family and layer: the first in row order, not picked by look."""


def compare(kin: Path, ref: Path, method: str) -> dict | None:
    """d3dwa compare's JSON record of method on kin against method on ref (None if refused)."""
    buffer, errors = io.StringIO(), io.StringIO()
    argv = ["compare", str(kin), "--methods", f"{method},{method}", "--against", str(ref), "--json"]
    with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(errors):
        code = d3dwa(argv)
    return (
        parse_json(buffer.getvalue(), ResultsError, "d3dwa compare --json") if code == 0 else None
    )


def reading(record: dict | None, profile: str, metric: str) -> dict | None:
    """The readings record of one profile's group and metric (None: not run or no pairs)."""
    if record is None:
        return None
    names = {g["group"]: g for g in record["groups"]}
    profiles = {name.rpartition(", noise ")[2] for name in names if ", noise " in name}
    # with one profile, compare pools the layouts in "all" and names no "all layouts" group
    pooled = "all" if profiles == {profile} else None
    group = names.get(f"all layouts, noise {profile}", names.get(pooled))
    return None if group is None else group.get("readings", {}).get(metric)


def cell_text(record: dict | None, profile: str, metric: str) -> str:
    """'reading: mean difference [interval], n=layouts' of one profile's group and metric."""
    if record is None:
        return "not run"
    r = reading(record, profile, metric)
    if not r:
        return "no pairs"
    if r.get("reading") is None or r.get("difference") is None:
        return reading_text_of(r) + ("" if r.get("layouts") is None else f", n={r['layouts']}")
    return f"{reading_text_of(r)}: {short(r, metric)}, n={r['layouts']}"


def reading_text_of(r: dict) -> str:
    """The testbed's own words for a reading (readings.reading_text), imported late: SciPy."""
    from d3dwa_bullet.evaluation.readings import reading_text

    return reading_text(r)


def short(r: dict, metric: str, points: str = " pt") -> str:
    """'+8.33 pt [-10, +26.7]' (success, in points, the unit ``points``) or '+0.0046 [-0.0012,
    +0.0094]' (score)."""
    scale, unit = (100.0, points) if metric == "success" else (1.0, "")
    interval = (
        "" if r.get("low") is None else f" [{scale * r['low']:+.3g}, {scale * r['high']:+.3g}]"
    )
    return f"{scale * r['difference']:+.3g}{unit}{interval}"


def verdict(success: dict | None, score: dict | None) -> str:
    """'yes' (the backend may answer) when both readings are equivalent within their margins
    (TOST rejects, a difference inside the margin included); otherwise 'no' and why: 'differs'
    (a difference that is not within the margin), 'eq. needs ~N' (the most layouts the
    repository's sizing, paired.layouts_for_equivalence at 80 % power, asks of a metric not yet
    equivalent), or 'eq. unreachable' (a mean difference at or beyond its margin: no number of
    layouts shows equivalence then); 'not run' without a reading."""
    if not success or not score:
        return "not run"
    readings = (success, score)
    if all(r.get("equivalent") for r in readings):
        return "yes"
    if any(r.get("reading") in ("A better", "B better") for r in readings):
        return "no: differs"
    open_ = [r for r in readings if not r.get("equivalent")]
    if any(r.get("needed_equivalence") is None for r in open_):
        return "no: eq. unreachable"
    return f"no: eq. needs ~{max(r['needed_equivalence'] for r in open_)}"


def table_row(family: str, layer: str, profile: str, method: str, record: dict | None) -> str:
    """One markdown row: the cell, n, both readings (kinematic - PyBullet) and the verdict."""
    success, score = (reading(record, profile, m) for m in METRICS)
    n = "" if not score else score.get("layouts", "")
    cells = [short(r, m, points="") if r and r.get("difference") is not None else "-"
             for r, m in ((success, "success"), (score, "score"))]  # fmt: skip
    cell = f"| {family} | {layer} | {profile} | {method} | {n} |"
    return f"{cell} {cells[0]} | {cells[1]} | {verdict(success, score)} |"


TABLE_HEAD = [
    "| family | layer | profile | method | n | success points, kin - PB [95 %] "
    "| score, kin - PB [95 %] | may answer |",
    "|---|---|---|---|---:|---|---|---|",
]


def disagreements(kin: Path, ref: Path) -> list[tuple[dict, dict]]:
    """(kinematic row, PyBullet row) of each episode whose outcomes differ, in kin's row order."""
    return [(k, r) for k, r in pairs_of(kin, ref) if k["outcome"] != r["outcome"]]


def pairs_of(kin: Path, ref: Path) -> list[tuple[dict, dict]]:
    """(kinematic row, PyBullet row) of each episode both directories ran, in kin's row order."""
    key = ("world", "method", "seed", "noise")
    theirs = {tuple(r[k] for k in key): r for r in read_results(ref)}
    return [(r, theirs[k]) for r in read_results(kin) if (k := tuple(r[c] for c in key)) in theirs]


def outcome_lines(name: str, pairs: list[tuple[dict, dict]]) -> list[str]:
    """How many pairs end differently, which way, and the rate's 95 % upper bound."""
    differ = [(k, r) for k, r in pairs if k["outcome"] != r["outcome"]]
    kin_goal = sum(k["outcome"] == "goal" for k, _ in differ)
    ref_goal = sum(r["outcome"] == "goal" for _, r in differ)
    if not pairs:
        return [f"- {name}: no pairs"]
    bound = stats.binomtest(len(differ), len(pairs)).proportion_ci(0.95).high
    return [
        f"- {name}: {len(pairs)} pairs, {len(differ)} with different outcomes",
        f"  (the goal on the kinematic side only: {kin_goal}, on PyBullet's only: {ref_goal});",
        f"  their rate at most {100 * bound:.1f} % (95 %, Clopper-Pearson)",
    ]


def study(
    runs: Path,
) -> tuple[list[str], list[str], list[str], list[tuple[Path, Path, tuple[dict, dict]]]]:
    """(table rows, full reading lines, outcome lines, the pairs to draw) of a runs directory."""
    table, lines, counts, drawn = list(TABLE_HEAD), [], [], []
    for family in FAMILIES:
        for layer, profiles in CONDITIONS:
            kin, ref = (runs / f"{family}-{layer}-{b}" for b in ("kinematic", "pybullet"))
            both = (kin / "results.csv").exists() and (ref / "results.csv").exists()
            records = {m: compare(kin, ref, m) if both else None for m in METHODS}
            for profile in profiles:
                for method in METHODS:
                    table.append(table_row(family, layer, profile, method, records[method]))
                    cells = [cell_text(records[method], profile, m) for m in METRICS]
                    lines += [f"- {family}, layer {layer}, {method}, {profile}:",
                              f"  success {cells[0]};", f"  robot score {cells[1]}"]  # fmt: skip
            if both:
                pairs = pairs_of(kin, ref)
                counts += outcome_lines(f"{family}, layer {layer}", pairs)
                counts += parting_lines(kin, ref, pairs)
                drawn += [(kin, ref, p) for p in disagreements(kin, ref)[:FIGURES]]
    return table, lines, counts, drawn


def write_page(
    page: Path, runs: Path, text: str, drawn: list[tuple[Path, Path, tuple[dict, dict]]]
) -> None:
    """readings.md, rows/ (each directory's results.csv and meta.json) and figures/ in page."""
    (page / "readings.md").write_text(
        "# Readings (tools/experiments/kinematic_agreement.py)\n\n" + text
    )
    for d in sorted(runs.iterdir()):
        if (d / "results.csv").exists():
            (page / "rows" / d.name).mkdir(parents=True, exist_ok=True)
            for name in ("results.csv", "meta.json"):
                shutil.copyfile(d / name, page / "rows" / d.name / name)
    (page / "figures").mkdir(exist_ok=True)
    for kin, ref, pair in drawn:
        row = pair[0]
        cell = kin.name.removesuffix("-kinematic")
        stem = f"{cell}__{row['world']}__{row['method']}__{row['noise']}"
        figure(kin, ref, pair, page / "figures" / f"{file_stem(stem)}.png")


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", help="the study's runs directory (runs/kinematic-agreement-2)")
    ap.add_argument("--page", help="write readings.md, rows/ and figures/ into this directory")
    args = ap.parse_args(argv)
    runs = Path(args.runs)
    if not runs.is_dir():
        ap.error(f"{runs}: not a directory")
    if args.page and not Path(args.page).is_dir():
        ap.error(f"--page {args.page}: not a directory")
    table, lines, counts, drawn = study(runs)
    text = "\n".join(
        ["Each cell: family, recovery layer, profile, method; the readings of kinematic - PyBullet,",
         "paired by layout (n layouts), and whether the kinematic backend may answer it.",
         "", *table, "", "## Each reading in the testbed's words", "", *lines, "",
         "## Outcomes and where the runs part", "", *counts]
    ) + "\n"  # fmt: skip
    print(text)
    if args.page:
        write_page(Path(args.page), runs, text, drawn)
        page = Path(args.page)
        print(f"page: {page / 'readings.md'}; {len(drawn)} figures in {page / 'figures'}")


if __name__ == "__main__":
    raise SystemExit(main())
