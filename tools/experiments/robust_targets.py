"""Issue 40's targets for one randomised method, each met or missed, from sweeps of its layouts.

Every figure is one that ``d3dwa compare`` or ``headroom`` prints for the same rows; this tool
only gathers them and reads each against the target the issue fixed (nothing is tuned here):

- under ``harsh``: P(M > ``d3dwa``) with its lower end above 0.5; P(M > DWA III) with its upper
  end at or above 0.5; success at least 88 %;
- under ``real``: P(M > DWA III) and P(M > ``d3dwa``), each with its upper end at or above 0.5;
- under ``none``: P(M > ``d3dwa``) with its upper end at or above 0.5;
- under every profile: M above the uniform chooser held at its decision period (``--floor``,
  default ``random@10``), one-sided paired p below 0.05;
- the moonshot: one training seed at or above 90 % under ``none``, ``real`` and ``harsh``.

P is the probability of improvement with its 95 % stratified bootstrap interval over training
seeds; the paired p is the one-sided Wilcoxon signed-rank test paired by layout, as the issue
asks (evaluation seeds pooled per layout; by (layout, evaluation seed) with ``--pair-by
layout-seed``, docs/design/learning-protocol.md#paired-test). Beside each paired p: how many layouts a test
would need for 80 % power if the per-layout differences were what these layouts show
(``paired.units_for_power``), a planning figure for the yardstick, not a test. Success is the
mean over layouts of each training seed's success there.

    python -m tools.experiments.robust_targets runs/profiles3-nav2 --also runs/r3-nav2
    python -m tools.experiments.robust_targets runs/seeds3-nav2 --method d3dwa-history-dr
    python -m tools.experiments.robust_targets runs/seeds3-nav2 --switch none=d3dwa,real=d3dwa,harsh=dwa3

``--switch`` reads the targets for ``headroom``'s profile-aware switch instead of a method: the
bound, so a target it misses is one no policy can be expected to meet on these layouts.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.paired import paired_scores, paired_test, units_for_power
from tools.entry import ToolParser, tool_main
from tools.experiments.headroom import (
    SWITCH,
    improvement_p,
    parse_switch,
    played,
    profile_rows,
    success,
)

Rows = Sequence[Mapping[str, Any]]
PROFILES = ("none", "real", "harsh")
NOT_BELOW = {"none": ("d3dwa",), "real": ("dwa3", "d3dwa"), "harsh": ("dwa3",)}
"""Per profile, the methods the randomised one must not be below (P upper end >= 0.5)."""
HARSH_SUCCESS = 0.88
MOONSHOT = 0.90
ALPHA = 0.05


def _record(profile: str, target: str, measured: str, met: bool, **figures: Any) -> dict[str, Any]:
    return {"profile": profile, "target": target, "measured": measured, "met": bool(met)} | figures


def _count(n: float) -> str:
    """A planning count: 'never' when A is not ahead, else rounded up to a whole unit."""
    return "never (it is not ahead)" if n == float("inf") else f"{math.ceil(n)}"


def _interval(p: Mapping[str, float]) -> str:
    return f"{p['p']:.2f} [{p['low']:.2f}, {p['high']:.2f}]"


def targets(
    sweeps: Sequence[Path],
    method: str,
    floor: str = "random@10",
    by_seed: bool = False,
    switch: Mapping[str, str] | None = None,
) -> list[dict[str, Any]]:
    """One record per target: profile, target, measured (text), met, and the figures. With
    ``switch`` (profile -> method) the candidate is the switch that plays it, named
    ``method``."""
    rows, _ = profile_rows(sweeps)
    for profile, chosen in (switch or {}).items():
        rows[profile] = [*rows[profile], *played(rows, profile, chosen, "--switch", method)]
    for profile in PROFILES:
        present = {r["method"] for r in rows.get(profile, [])}
        for m in (method, *NOT_BELOW[profile], "d3dwa", floor):
            if m not in present:
                where = ", ".join(map(str, sweeps))
                raise ResultsError(f"{where}: no rows of {m!r} under profile {profile!r}")
    out: list[dict[str, Any]] = []
    for profile in PROFILES:
        here = rows[profile]
        if profile == "harsh":
            p = improvement_p(here, method, "d3dwa")
            out.append(_record(profile, "beats d3dwa (P lower end > 0.5)", _interval(p),
                               p["low"] > 0.5, **p))  # fmt: skip
        for other in NOT_BELOW[profile]:
            p = improvement_p(here, method, other)
            out.append(_record(profile, f"not below {other} (P upper end >= 0.5)", _interval(p),
                               p["high"] >= 0.5, **p))  # fmt: skip
        if profile == "harsh":
            s = success([r for r in here if r["method"] == method])
            out.append(_record(profile, f"success >= {HARSH_SUCCESS:.0%}",
                               f"{s['success']:.1%} [{s['low']:.1%}, {s['high']:.1%}]",
                               s["success"] >= HARSH_SUCCESS, **s))  # fmt: skip
        scores = paired_scores(here, method, floor, by_seed)
        test = paired_test(scores)
        pv, need = test["p"], units_for_power(scores, ALPHA)
        unit = "layouts" if not by_seed else "units"
        power = "" if need is None else f"; 80 % power needs {_count(need)} {unit}"
        out.append(_record(profile, f"above {floor} (paired p < {ALPHA})",
                           "n/a" if pv is None else f"p {pv:.3g} ({test['wins']} better / {test['losses']} worse{power})",
                           pv is not None and pv < ALPHA, **test, units_for_power=need))  # fmt: skip
    worst = _worst_profile_per_seed(
        {p: [r for r in rows[p] if r["method"] == method] for p in PROFILES}
    )
    best = max(worst, key=lambda k: worst[k])
    out.append(_record("all", f"moonshot: one seed >= {MOONSHOT:.0%} under {', '.join(PROFILES)}",
                       f"{'its one run' if best is None else f'seed {best}'}: {worst[best]:.1%} at its worst profile",
                       worst[best] >= MOONSHOT, worst_per_seed=worst))  # fmt: skip
    return out


def _worst_profile_per_seed(rows: Mapping[str, Rows]) -> dict[Any, float]:
    """Each training seed's success at its worst profile. A profile whose rows have no
    training seed (a fixed method, as the switch plays DWA III under `harsh`) counts for every
    seed."""
    goals: dict[str, dict[Any, list[bool]]] = {p: defaultdict(list) for p in rows}
    for profile, rs in rows.items():
        for r in rs:
            goals[profile][r["policy_seed"]].append(r["outcome"] == "goal")
    seeds = {k for per in goals.values() for k in per if k is not None} or {None}
    missing = [p for p, per in goals.items() if not per]
    if missing:
        raise ResultsError(f"no rows under profile {', '.join(missing)}")
    rate = {p: {k: float(np.mean(per[k] if k in per else per[None])) for k in seeds}
            for p, per in goals.items()}  # fmt: skip
    return {k: min(rate[p][k] for p in rows) for k in sorted(seeds, key=str)}


def markdown(records: Sequence[Mapping[str, Any]], method: str) -> str:
    lines = [f"| profile | target for {method} | measured | met |", "|---|---|---|---|"]
    lines += [f"| {r['profile']} | {r['target']} | {r['measured']} | {'yes' if r['met'] else 'no'} |"
              for r in records]  # fmt: skip
    met = sum(r["met"] for r in records)
    return "\n".join(lines) + f"\n\n{met} of {len(records)} targets met.\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="robust_targets", description=__doc__.split("\n")[0])
    parser.add_argument("sweep", type=Path, help="a `d3dwa sweep` with profiles none, real, harsh")
    parser.add_argument("--method", help="the randomised method (default d3dwa-dr)")
    parser.add_argument("--floor", default="random@10",
                        help="the uniform chooser at the method's period (default %(default)s)")  # fmt: skip
    parser.add_argument("--also", type=Path, action="append", default=[], metavar="SWEEP",
                        help="more methods from another sweep of the same layouts")  # fmt: skip
    parser.add_argument("--pair-by", choices=("layout-seed", "layout"), default="layout",
                        help="the paired test's unit, as in `d3dwa compare` (default %(default)s, "
                        "the issue's: evaluation seeds pooled per layout)")  # fmt: skip
    parser.add_argument("--switch", metavar="PROFILE=METHOD,...",
                        help="the candidate is headroom's switch (none, real and harsh each named)")  # fmt: skip
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    switch, method = None, args.method or "d3dwa-dr"
    if args.switch:
        if args.method:
            parser.error("--method and --switch name two candidates: give one")
        switch, method = parse_switch(args.switch), SWITCH
        if missing := [p for p in PROFILES if p not in switch]:
            parser.error(f"--switch names no method for profile {', '.join(missing)}")
    records = targets(
        [args.sweep, *args.also], method, args.floor, args.pair_by != "layout", switch
    )
    print(json.dumps(records, indent=1) if args.json else markdown(records, method), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
