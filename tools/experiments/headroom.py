"""The headroom a randomised policy should approach: a switch that knows the noise profile.

A diagnostic, not a method (SPEC 7): under each profile it plays the method it is told to
(by default the noise-free policy ``d3dwa`` under ``none``, ``paper`` and ``real``, and the
fixed planner DWA III under ``harsh``). Episodes are deterministic given the layout, the
episode seed and the method, so the switch's episode under a profile *is* that method's
episode in the sweep: the switch is read from a sweep directory, not run again. Beside it, per
profile: every method of the sweep and the best fixed tuple in hindsight (the fixed method with
the most goals under that profile, chosen after looking, which only a bound may do). Success
is the mean over layouts of each training seed's success, with the 95 % stratified bootstrap
interval over training seeds (``d3dwa eval``'s statistic).

    d3dwa sweep --axes '' --recovery nav2 --profiles none,paper,real,harsh --out runs/profiles
    python -m tools.experiments.headroom runs/profiles
    python -m tools.experiments.headroom runs/profiles --switch none=d3dwa,real=d3dwa,harsh=dwa3
    python -m tools.experiments.headroom runs/profiles --paired --also runs/r3-nav2

``--paired`` asks whether the bound itself would meet issue 40's targets on the sweep's layouts:
per profile, the switch against every method (of the sweep and of each ``--also`` sweep), with
``d3dwa compare``'s two statistics, P(switch > method) with its interval over training seeds and
the one-sided Wilcoxon p paired by layout. A target the switch misses is one no policy can be
expected to meet on these layouts.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.paired import paired_scores, paired_test
from d3dwa_bullet.evaluation.results import job_rows
from d3dwa_bullet.evaluation.seed_stats import mean_interval
from d3dwa_bullet.evaluation.seed_tables import improvement, success_scores
from d3dwa_bullet.evaluation.sweep import profile_of
from d3dwa_bullet.method_specs import FIXED
from tools.entry import ToolParser, tool_main

DEFAULT_SWITCH = {"none": "d3dwa", "paper": "d3dwa", "real": "d3dwa", "harsh": "dwa3"}
SWITCH = "headroom"


def parse_switch(text: str) -> dict[str, str]:
    """``profile=method,...`` as a mapping; ResultsError naming a malformed item."""
    out: dict[str, str] = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        profile, sep, method = item.partition("=")
        if not sep or not profile or not method:
            raise ResultsError(f"--switch: {item!r} is not PROFILE=METHOD")
        out[profile] = method
    if not out:
        raise ResultsError("--switch: empty")
    return out


def success(rows: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Mean success over layouts of each training seed's per-layout success, with interval."""
    layouts: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        layouts[r["world"]].append(r)
    i = mean_interval([success_scores(rs) for rs in layouts.values()])
    return {"success": i.value, "low": i.low, "high": i.high, "layouts": len(layouts)}


def headroom(sweep: Path, switch: Mapping[str, str]) -> list[dict[str, Any]]:
    """One record per profile of the switch: the switch's success, every method's, and the
    best fixed tuple's in hindsight."""
    if not (sweep / "results.csv").is_file():
        raise ResultsError(f"{sweep}: no results.csv")
    cells: dict[tuple[str, str], list[Mapping[str, Any]]] = defaultdict(list)
    for r in job_rows(sweep):
        profile = profile_of(r)
        if profile is not None:
            cells[(profile, r["method"])].append(r)
    methods = list(dict.fromkeys(m for _, m in cells))
    records = []
    for profile, chosen in switch.items():
        if (profile, chosen) not in cells:
            raise ResultsError(f"{sweep}: no rows of {chosen!r} under profile {profile!r}")
        per = {m: success(cells[(profile, m)]) for m in methods if (profile, m) in cells}
        fixed = [m for m in per if m in FIXED]
        best = max(fixed, key=lambda m: per[m]["success"]) if fixed else None
        records.append({"profile": profile, "switch": chosen, SWITCH: per[chosen],
                        "best_fixed": best, "methods": per})  # fmt: skip
    return records


def profile_rows(
    sweeps: Sequence[Path],
) -> tuple[dict[str, list[Mapping[str, Any]]], dict[str, int]]:
    """Each profile's rows over the sweeps, and which sweep (its index) holds each method;
    ResultsError naming a sweep without results or a method two sweeps both hold (the rows
    would mix two runs of it)."""
    by_profile: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    owner: dict[str, int] = {}
    for i, sweep in enumerate(sweeps):
        if not (sweep / "results.csv").is_file():
            raise ResultsError(f"{sweep}: no results.csv")
        for r in job_rows(sweep):
            if owner.setdefault(r["method"], i) != i:
                raise ResultsError(
                    f"{sweep}: method {r['method']!r} is also in {sweeps[owner[r['method']]]}"
                )
            profile = profile_of(r)
            if profile is not None:
                by_profile[profile].append(r)
    return by_profile, owner


def played(
    rows: Mapping[str, Sequence[Mapping[str, Any]]],
    profile: str,
    chosen: str,
    where: str,
    name: str = SWITCH,
) -> list[dict[str, Any]]:
    """The switch's rows under ``profile``: those of the method it plays there (``chosen``),
    renamed ``name``; ResultsError naming ``where`` when that method has none."""
    out = [{**r, "method": name} for r in rows.get(profile, []) if r["method"] == chosen]
    if not out:
        raise ResultsError(f"{where}: no rows of {chosen!r} under profile {profile!r}")
    return out


def improvement_p(rows: Sequence[Mapping[str, Any]], a: str, b: str) -> dict[str, float]:
    """P(a > b) over every task both ran, with its 95 % interval: {"p", "low", "high"}."""
    p = improvement(rows, a, b, lambda r: ())[-1]
    return {"p": p["p"], "low": p["low"], "high": p["high"]}


def paired(
    sweeps: Sequence[Path], switch: Mapping[str, str], by_seed: bool = True
) -> list[dict[str, Any]]:
    """Per profile of the switch and per method under it: P(switch > method) with its 95 %
    interval over training seeds, and the paired one-sided Wilcoxon test of switch > method
    by (layout, evaluation seed), or by layout pooling the evaluation seeds unless by_seed
    (``d3dwa compare``'s statistics and its --pair-by). sweeps[0] holds the switch's methods."""
    rows, owner = profile_rows(sweeps)
    records: list[dict[str, Any]] = []
    for profile, chosen in switch.items():
        switched = played(rows, profile, chosen, str(sweeps[0]))
        if owner[chosen] != 0:
            raise ResultsError(f"{sweeps[0]}: no rows of {chosen!r} under profile {profile!r}")
        for method in dict.fromkeys(r["method"] for r in rows[profile]):
            both = switched + [r for r in rows[profile] if r["method"] == method]
            test = paired_test(paired_scores(both, SWITCH, method, by_seed))
            records.append({"profile": profile, "switch": chosen, "method": method}
                           | improvement_p(both, SWITCH, method)
                           | {f"paired_{k}": v for k, v in test.items()})  # fmt: skip
    return records


def paired_markdown(records: Sequence[Mapping[str, Any]]) -> str:
    head = ["profile (switch plays)", "against", "P(switch > it)", "paired p (switch > it)",
            "layouts better / worse"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for r in records:
        p = "" if r["paired_p"] is None else f"{r['paired_p']:.3g}"
        lines.append(
            f"| {r['profile']} ({r['switch']}) | {r['method']} | {r['p']:.2f} "
            f"[{r['low']:.2f}, {r['high']:.2f}] | {p} | "
            f"{r['paired_wins']} / {r['paired_losses']} |"
        )
    return "\n".join(lines) + "\n"


def _cell(s: Mapping[str, float]) -> str:
    if s["low"] == s["high"]:
        return f"{100 * s['success']:.0f}"
    return f"{100 * s['success']:.0f} [{100 * s['low']:.0f}, {100 * s['high']:.0f}]"


def markdown(records: Sequence[Mapping[str, Any]]) -> str:
    methods = list(dict.fromkeys(m for r in records for m in r["methods"]))
    head = ["profile", "headroom (plays)", "best fixed in hindsight", *methods]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for r in records:
        best = r["best_fixed"]
        best_cell = f"{best} {_cell(r['methods'][best])}" if best else ""
        cells = [r["profile"], f"{_cell(r[SWITCH])} ({r['switch']})", best_cell]
        cells += [_cell(r["methods"][m]) if m in r["methods"] else "" for m in methods]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="headroom", description=__doc__.split("\n")[0])
    parser.add_argument("sweep", type=Path, help="a `d3dwa sweep` directory with named profiles")
    parser.add_argument("--switch", default=",".join(f"{p}={m}" for p, m in DEFAULT_SWITCH.items()),
                        help="PROFILE=METHOD,... (default: %(default)s)")  # fmt: skip
    parser.add_argument(
        "--paired",
        action="store_true",
        help="the switch against every method, P and the paired p per profile",
    )
    parser.add_argument(
        "--also",
        type=Path,
        action="append",
        default=[],
        metavar="SWEEP",
        help="with --paired: more methods from another sweep of the same layouts",
    )
    parser.add_argument(
        "--pair-by",
        choices=("layout-seed", "layout"),
        help="with --paired: the paired test's unit, as in `d3dwa compare` (default layout-seed)",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if args.also and not args.paired:
        parser.error("--also needs --paired")
    if args.pair_by and not args.paired:
        parser.error("--pair-by needs --paired")
    if args.paired:
        by_seed = args.pair_by != "layout"
        records = paired([args.sweep, *args.also], parse_switch(args.switch), by_seed)
        text = paired_markdown(records)
    else:
        records = headroom(args.sweep, parse_switch(args.switch))
        text = markdown(records)
    print(json.dumps(records, indent=1) if args.json else text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
