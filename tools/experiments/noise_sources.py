"""Which noise source breaks a method: a profile with one source removed, or one source alone.

``harsh`` changes every source at once. ``write`` splits a noisy profile (default ``harsh``)
against an off profile (default ``none``) into nine sources and writes, per source, the
noisy profile with that source set to its off value (``<base>-no-<source>.yaml``) and the off
profile with only that source at its noisy value (``<base>-only-<source>.yaml``). A sweep run
over those files (``d3dwa sweep --axes '' --profiles DIR/a.yaml,...``) gives one success rate
per method and condition; ``table`` prints them beside the base profile and ``none``, with each
condition's change against the base (removed) or against ``none`` (alone), and the failures
that ended in a fallback storm (:mod:`d3dwa_bullet.evaluation.failures`).

    python -m tools.experiments.noise_sources write --out runs/sources
    d3dwa sweep --axes '' --recovery nav2 --profiles harsh,$(ls runs/sources/*.yaml | paste -sd,) \\
        --methods dwa3,d3dwa,d3dwa-dr --policy-seeds 0,1 --out runs/sources-sweep
    python -m tools.experiments.noise_sources table runs/sources-sweep
"""

from __future__ import annotations

import copy
import json
from collections import Counter, defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.failures import classify
from d3dwa_bullet.evaluation.jobs import row_log
from d3dwa_bullet.evaluation.results import job_rows
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.resources import profiles_dir
from randomization.profiles import load_profile
from tools.entry import ToolParser, tool_main

#: A source: the (group, fields) of a profile's params it owns; ``None`` is the whole group.
SOURCES: dict[str, tuple[str, tuple[str, ...] | None]] = {
    "lidar_range": ("lidar", ("range_std",)),
    "lidar_dropout": ("lidar", ("dropout_prob", "dropout_kinds")),
    "lidar_spurious": ("lidar", ("spurious_prob", "spurious_min", "spurious_max")),
    "slip": ("slip", None),
    "odometry": ("odometry", None),
    "gyro": ("imu", None),
    "latency": ("latency", None),
    "physics": ("physics", None),
    "pose_fix": ("pose_fix", None),
}


def _params(name: str) -> dict[str, Any]:
    load_profile(name)  # validated, or a ProfileError naming it
    path = Path(name) if name.endswith((".yaml", ".yml")) else profiles_dir() / f"{name}.yaml"
    data = load_yaml(path, ResultsError, "profile YAML")
    return copy.deepcopy(dict(data["params"]))


def _take(dst: dict[str, Any], src: Mapping[str, Any], source: str) -> None:
    group, keys = SOURCES[source]
    if keys is None:
        dst[group] = copy.deepcopy(src[group])
        return
    for key in keys:
        dst[group][key] = copy.deepcopy(src[group][key])


def split_profiles(base: str, off: str) -> dict[str, dict[str, Any]]:
    """File stem -> profile mapping: the base without each source, and each source alone."""
    noisy, quiet = _params(base), _params(off)
    out: dict[str, dict[str, Any]] = {}
    for source in SOURCES:
        removed = copy.deepcopy(noisy)
        _take(removed, quiet, source)
        alone = copy.deepcopy(quiet)
        _take(alone, noisy, source)
        for stem, params, what in (
            (f"{base}-no-{source}", removed, f"{base} with {source} off"),
            (f"{base}-only-{source}", alone, f"{source} at its {base} level, all else off"),
        ):
            out[stem] = {"name": stem, "version": 1, "description": what, "params": params}
    return out


def write(base: str, off: str, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, profile in split_profiles(base, off).items():
        path = out / f"{stem}.yaml"
        atomic_write_text(path, yaml.safe_dump(profile, sort_keys=False))
        load_profile(path)  # every written file loads
        paths.append(path)
    return paths


def condition(noise: str) -> str:
    """A row's noise label as a condition name: a profile file's stem, else the name."""
    return Path(noise).stem if noise.endswith((".yaml", ".yml")) else noise


def records(sweep: Path) -> list[dict[str, Any]]:
    """One record per (condition, method): episodes, goals, storms among the failures."""
    if not (sweep / "results.csv").is_file():
        raise ResultsError(f"{sweep}: no results.csv")
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in job_rows(sweep):
        if r["axis"] in ("none", "profile"):
            groups[(condition(r["noise"]), r["method"])].append(r)
    out = []
    for (cond, method), rs in sorted(groups.items()):
        modes: Counter[str] = Counter()
        for r in rs:
            if r["outcome"] != "goal":
                modes[classify(row_log(sweep, r))["mode"]] += 1
        goals = sum(r["outcome"] == "goal" for r in rs)
        out.append({"condition": cond, "method": method, "episodes": len(rs), "goals": goals,
                    "success": goals / len(rs), "modes": dict(modes)})  # fmt: skip
    return out


def markdown(recs: Sequence[Mapping[str, Any]], base: str = "harsh") -> str:
    """Success [%] per condition (rows) and method (columns), with the change and storms."""
    methods = list(dict.fromkeys(r["method"] for r in recs))
    by = {(r["condition"], r["method"]): r for r in recs}
    order = ["none", base]
    order += [f"{base}-no-{s}" for s in SOURCES] + [f"{base}-only-{s}" for s in SOURCES]
    head = "| condition | " + " | ".join(f"{m} [%] (change; storms)" for m in methods) + " |"
    lines = [head, "|---" * (len(methods) + 1) + "|"]
    for cond in [c for c in order if any((c, m) in by for m in methods)]:
        ref = "none" if "-only-" in cond else base
        cells = []
        for m in methods:
            r = by.get((cond, m))
            if r is None:
                cells.append("")
                continue
            cell = f"{100 * r['success']:.0f}"
            if cond not in ("none", base) and (ref, m) in by:
                cell += f" ({100 * (r['success'] - by[(ref, m)]['success']):+.0f}"
                cell += f"; {r['modes'].get('fallback storm', 0)})"
            else:
                cell += f" ({r['modes'].get('fallback storm', 0)} storms)"
            cells.append(cell)
        lines.append(f"| {cond} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="noise_sources", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    w = sub.add_parser("write", help="write the one-source-removed and one-source-alone profiles")
    w.add_argument("--base", default="harsh", help="the noisy profile (name or YAML)")
    w.add_argument("--off", default="none", help="the profile whose values mean 'off'")
    w.add_argument("--out", type=Path, required=True)
    t = sub.add_parser("table", help="success and storms per condition from a sweep directory")
    t.add_argument("sweep", type=Path)
    t.add_argument("--base", default="harsh")
    t.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if args.command == "write":
        for path in write(args.base, args.off, args.out):
            print(path)
        return 0
    recs = records(args.sweep)
    print(json.dumps(recs, indent=1) if args.json else markdown(recs, args.base), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
