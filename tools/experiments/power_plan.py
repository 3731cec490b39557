"""How many layouts a comparison needs to end in a reading, from a pilot: the power plan.

For each method pair (``--pair A,B``, repeated), noise profile and metric (success, the
score, BARN's official score), from the pilot's per-layout differences A - B (each side
averaged over its training and evaluation seeds on a layout, as ``d3dwa compare``'s readings
pair them): the observed mean difference, the sd of the differences, the layouts in the
pilot, and the layouts a yardstick needs for 80 % power, for the one-sided paired t-test
(alpha 0.025 each way) and for TOST against the margin (alpha 0.05), by the normal
approximation with the observed mean and sd taken as the truth
(``readings.plan_of``, docs/design/readings.md#readings). The plan aims at the reading that needs the
fewer layouts. Margins are stated here, before the sweep, with the flags ``compare`` takes.

    python -m tools.experiments.power_plan runs/pilot --pair d3dwa,d3dwa-weights --pair d3dwa-dr,dwa3
    python -m tools.experiments.power_plan runs/pilot --also runs/pilot-floors --pair d3dwa,random@10 --json

A planning figure, not a test: commit it before the sweep it sizes (SPEC section 9).
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.margins import (
    MARGIN_OPTIONS,
    MARGINS,
    check_margin,
    margin_text,
    option_value,
)
from d3dwa_bullet.evaluation.paired import METRICS, paired_scores
from d3dwa_bullet.evaluation.readings import NO_SCORE, missing_metric, plan_of
from d3dwa_bullet.evaluation.results import check_results_dir, job_rows
from tools.entry import ToolParser, tool_main

Rows = Sequence[Mapping[str, Any]]


def pilot_rows(pilots: Sequence[Path]) -> list[Mapping[str, Any]]:
    """The rows of every pilot directory; ResultsError naming a directory without results or a
    method two directories both hold (the rows would mix two runs of it)."""
    rows: list[Mapping[str, Any]] = []
    owner: dict[str, Path] = {}
    for pilot in pilots:
        if not (pilot / "results.csv").is_file():
            raise ResultsError(f"{pilot}: not a results directory (no results.csv)")
        check_results_dir(pilot)
        for r in job_rows(pilot):
            if owner.setdefault(r["method"], pilot) != pilot:
                raise ResultsError(
                    f"{pilot}: method {r['method']!r} is also in {owner[r['method']]}"
                )
            rows.append(r)
    return rows


def plan(
    rows: Rows, pairs: Sequence[tuple[str, str]], margins: Mapping[str, float]
) -> list[dict[str, Any]]:
    """One record per (pair, profile, metric of margins): {"a", "b", "profile", "metric"} and
    :func:`readings.plan_of`'s figures; a metric some row lacks has why = NO_SCORE.
    ResultsError naming a method of a pair that no row has."""
    present = {r["method"] for r in rows}
    by_profile: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        by_profile[r["noise"]].append(r)
    out = []
    for a, b in pairs:
        for m in (a, b):
            if m not in present:
                raise ResultsError(
                    f"no rows of method {m!r} (the pilot has {', '.join(sorted(present))})"
                )
        for profile, here in by_profile.items():
            mine = [r for r in here if r["method"] in (a, b)]
            if not {a, b} <= {r["method"] for r in mine}:
                continue
            for metric, margin in margins.items():
                head: dict[str, Any] = {"a": a, "b": b, "profile": profile, "metric": metric}
                if missing_metric(mine, metric):
                    layouts = len(paired_scores(mine, a, b, by_seed=False))
                    out.append(head | {"margin": margin, "layouts": layouts, "aim": None,
                                       "why": NO_SCORE})  # fmt: skip
                    continue
                scores = paired_scores(mine, a, b, by_seed=False, metric=metric)
                out.append(head | plan_of(scores, margin))
    return out


def _figure(x: float | None, metric: str) -> str:
    if x is None:
        return "--"
    return f"{100 * x:+.1f}" if metric == "success" else f"{x:+.4f}"


def markdown(records: Sequence[Mapping[str, Any]]) -> str:
    lines = [
        "| A | B | profile | metric (margin) | mean A - B | sd | pilot layouts | "
        "difference test needs | TOST needs | the plan aims at |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for r in records:
        metric = r["metric"]
        sd = "--" if r.get("sd") is None else _figure(r["sd"], metric).lstrip("+")
        aim = r["why"] if r["aim"] is None else (
            f"{r['aim']}" + (f" within {margin_text(metric, r['margin'])}"
                             if r["aim"] == "equivalent" else "")
            + f": {r['needed']} layouts"
        )  # fmt: skip
        need = ["never" if r.get(k) is None and r["aim"] else str(r.get(k) or "--")
                for k in ("needed_difference", "needed_equivalence")]  # fmt: skip
        lines.append(
            f"| {r['a']} | {r['b']} | {r['profile']} | {metric} "
            f"({margin_text(metric, r['margin'])}) | {_figure(r.get('difference'), metric)} | "
            f"{sd} | {r.get('layouts', '--')} | {need[0]} | {need[1]} | {aim} |"
        )
    note = (
        "\nSuccess in points. Layouts for 80 % power if the pilot's mean and sd were the truth "
        "(normal approximation; difference at alpha 0.025 each way, TOST at 0.05).\n"
    )
    return "\n".join(lines) + "\n" + note


def _pair(text: str) -> tuple[str, str]:
    names = [m.strip() for m in text.split(",")]
    if len(names) != 2 or not all(names) or names[0] == names[1]:
        raise ValueError(text)
    return names[0], names[1]


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="power_plan", description=__doc__.split("\n")[0])
    parser.add_argument("pilot", type=Path, help="a pilot results directory (eval or sweep)")
    parser.add_argument("--also", type=Path, action="append", default=[], metavar="DIR",
                        help="more methods from another pilot of the same layouts")  # fmt: skip
    parser.add_argument("--pair", action="append", required=True, metavar="A,B",
                        help="two different methods to plan for (repeat for more pairs)")  # fmt: skip
    parser.add_argument("--metrics", default=",".join(METRICS),
                        help="comma-separated, of %(default)s (default all)")  # fmt: skip
    for metric, option in MARGIN_OPTIONS.items():
        parser.add_argument(option, type=float, default=option_value(metric, MARGINS[metric]),
                            help="equivalence margin, as `d3dwa compare` takes it "
                            "(default %(default)g)")  # fmt: skip
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    metrics = [m.strip() for m in args.metrics.split(",") if m.strip()]
    unknown = [m for m in metrics if m not in METRICS]
    if not metrics or unknown:
        parser.error(f"--metrics: {', '.join(unknown) or repr(args.metrics)} is not one of "
                     f"{', '.join(METRICS)}")  # fmt: skip
    margins = {m: check_margin(getattr(args, MARGIN_OPTIONS[m][2:].replace("-", "_")), m)
               for m in metrics}  # fmt: skip
    pairs = []
    for text in args.pair:
        try:
            pairs.append(_pair(text))
        except ValueError:
            parser.error(f"--pair needs two different methods A,B, got {text!r}")
    records = plan(pilot_rows([args.pilot, *args.also]), pairs, margins)
    print(json.dumps(records, indent=1) if args.json else markdown(records), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
