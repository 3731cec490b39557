"""Methods of several sweeps side by side: success per noise profile, as a bar chart.

Each entry is ``LABEL=DIR:METHOD``: the rows of METHOD in the sweep directory DIR. A bar is
the mean over layouts of each training seed's success with its 95 % stratified bootstrap
interval over training seeds (``d3dwa eval``'s statistic, ``headroom.success``); a fixed or
reference method's single run has none. Entries must share their layouts under each profile,
or the bars would not be comparable: a profile where they differ is refused, naming both.

    python -m tools.experiments.recipes_figure --out docs/figures/recipes.png \\
      "recipe 3=runs/r3-nav2:d3dwa-dr" "recipe 6=runs/r6-nav2:d3dwa-dr" \\
      "d3dwa=runs/profiles3-nav2:d3dwa" "DWA III=runs/profiles3-nav2:dwa3"
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import D3DWAError, ResultsError
from d3dwa_bullet.evaluation.results import job_rows
from d3dwa_bullet.evaluation.sweep import profile_of
from tools.entry import ToolParser, fail, tool_main
from tools.experiments.headroom import success

PROFILE_ORDER = ("none", "paper", "real", "harsh")


def parse_entry(text: str) -> tuple[str, Path, str]:
    """``LABEL=DIR:METHOD`` as (label, dir, method); ResultsError naming a malformed one."""
    label, sep, rest = text.partition("=")
    folder, colon, method = rest.rpartition(":")
    if not sep or not colon or not label.strip() or not folder or not method:
        raise ResultsError(f"entry {text!r} is not LABEL=DIR:METHOD")
    return label.strip(), Path(folder), method


def collect(entries: Sequence[tuple[str, Path, str]]) -> dict[str, dict[str, dict[str, float]]]:
    """{label: {profile: success record}} over the named profiles every entry has."""
    cells: dict[str, dict[str, list[Mapping[str, Any]]]] = {}
    for label, folder, method in entries:
        if not (folder / "results.csv").is_file():
            raise ResultsError(f"{folder}: no results.csv")
        by_profile: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
        for r in job_rows(folder):
            profile = profile_of(r)
            if r["method"] == method and profile is not None:
                by_profile[profile].append(r)
        if not by_profile:
            raise ResultsError(f"{folder}: no rows of {method!r} under a named profile")
        cells[label] = by_profile
    shared = set.intersection(*(set(c) for c in cells.values()))
    profiles = [p for p in PROFILE_ORDER if p in shared] + sorted(shared - set(PROFILE_ORDER))
    if not profiles:
        raise ResultsError("the entries share no noise profile")
    first = entries[0][0]
    for profile in profiles:
        want = {r["world"] for r in cells[first][profile]}
        for label in cells:
            got = {r["world"] for r in cells[label][profile]}
            if got != want:
                raise ResultsError(
                    f"under {profile!r}, {label!r} has {len(got)} layouts and {first!r} "
                    f"{len(want)}, not the same ones: bars over different layouts do not compare"
                )
    return {label: {p: success(c[p]) for p in profiles} for label, c in cells.items()}


def draw(data: Mapping[str, Mapping[str, Mapping[str, float]]], out: Path, title: str) -> Path:
    """One column per profile, one point per entry with its interval, written atomically.
    Points, not bars: the axis starts where the data do, which a bar would misstate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from d3dwa_bullet.evaluation.plotting import save_figure  # with matplotlib, for the figure only

    labels = list(data)
    profiles = list(next(iter(data.values())))
    step = 0.7 / max(len(labels) - 1, 1)
    fig, ax = plt.subplots(figsize=(2.5 + len(profiles) * (0.9 + 0.25 * len(labels)), 4.0))
    lows = []
    for i, label in enumerate(labels):
        xs = [j - 0.35 + i * step for j in range(len(profiles))]
        s = [data[label][p] for p in profiles]
        ys = [100 * c["success"] for c in s]
        err = [[y - 100 * c["low"] for y, c in zip(ys, s, strict=True)],
               [100 * c["high"] - y for y, c in zip(ys, s, strict=True)]]  # fmt: skip
        ax.errorbar(xs, ys, yerr=err, fmt="o", capsize=3, label=label)
        for x, y in zip(xs, ys, strict=True):
            ax.annotate(f"{y:.0f}", (x, y), xytext=(4, 0), textcoords="offset points",
                        fontsize=7, va="center")  # fmt: skip
        lows += [100 * c["low"] for c in s]
    ax.set_xticks(range(len(profiles)), profiles)
    ax.set_xlim(-0.6, len(profiles) - 0.4)
    ax.set_ylim(max(0.0, 10 * (min(lows) // 10) - 5), 100)
    ax.set_ylabel("success [%], 95 % interval over training seeds")
    ax.set_title(title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    for j in range(1, len(profiles)):
        ax.axvline(j - 0.5, color="0.85", lw=0.8)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return save_figure(fig, out, dpi=110)


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="recipes_figure", description=__doc__.split("\n")[0])
    parser.add_argument("entries", nargs="+", help="LABEL=DIR:METHOD, one per bar")
    parser.add_argument("--out", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--title", default="Success on the sweep's layouts")
    parser.add_argument("--json", action="store_true", help="print the bars' numbers as JSON")
    args = parser.parse_args(argv)
    if args.out.suffix.lower() != ".png":
        fail("recipes_figure", f"--out {args.out} must end in .png")
    try:
        data = collect([parse_entry(e) for e in args.entries])
    except D3DWAError as exc:
        fail("recipes_figure", str(exc))
    draw(data, args.out, args.title)
    if args.json:
        print(json.dumps(data, indent=1))
    else:
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
