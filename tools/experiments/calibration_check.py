"""Does a calibrated profile bring the simulated lidar closer to the source robot than its base?

1. A "source robot" with a known, distinctly non-default lidar (2 cm range noise, 15 %
   dropout on its right-hand sectors and 2.5 % elsewhere, every invalid kind including
   -inf and out-of-range, 0.5 % phantoms) is recorded driving a simulated episode
   (``d3dwa record --noise source.yaml``), so its scans share the simulator's geometry and
   only the noise differs.
2. ``d3dwa calibrate`` fits a profile to that bag on top of ``--base``.
3. Two more episodes are recorded with another seed, one under the calibrated profile and one
   under the base profile, and ``d3dwa compare-scans`` compares each with the source.

Figures: per sector, the valid ratio and each invalid kind's share of the beams, and the
consecutive-scan noise figure of compare-scans; summed as the mean absolute difference to
the source over the 8 sectors (lower is closer).

    python -m tools.experiments.calibration_check --json
    python -m tools.experiments.calibration_check --world H1 --time-limit 15 --out /tmp/check
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from d3dwa_bullet.cli.app import main as d3dwa
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.loading import load_yaml, parse_json
from randomization.profiles import load_profile
from tools.entry import ToolParser, tool_main
from transfer.compare import READING_CLASSES

#: The source robot's lidar (randomization profile params.lidar); the rest is the base's.
SOURCE_LIDAR = {
    "range_std": 0.02,
    "dropout_prob": 0.025,
    "dropout_kinds": [0.1, 0.7, 0.2],
    "spurious_prob": 0.005,
    "spurious_min": 0.2,
    "spurious_max": 0.8,
    "dropout_sector_scale": [6.0, 6.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    "dropout_sector_kinds": [[0.3, 0.2, 0.2, 0.2, 0.1]] * 2 + [[0.1, 0.6, 0.1, 0.1, 0.1]] * 6,
}


def _run(*argv: object) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = d3dwa([str(a) for a in argv])
    if code != 0:
        raise SystemExit(f"d3dwa {' '.join(map(str, argv))} failed with status {code}")
    return out.getvalue()


def _figures(stats: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for s in stats["sectors"]:
        beams = s["beams"] or 1
        row = {"valid": s["valid_ratio"], "noise_mm": None}
        row.update({c: s[c] / beams for c in READING_CLASSES})
        if s["noise_std"] is not None:
            row["noise_mm"] = 1000 * s["noise_std"]
        rows.append(row)
    return rows


def _distance(a: list[dict[str, Any]], b: list[dict[str, Any]], key: str) -> float:
    pairs = [(x[key], y[key]) for x, y in zip(a, b, strict=True) if None not in (x[key], y[key])]
    return sum(abs(x - y) for x, y in pairs) / max(len(pairs), 1)


def check(
    out: Path, world: str, method: str, base: str, time_limit: float, seeds: tuple[int, int]
) -> dict[str, Any]:
    data = load_yaml(load_profile(base).source, ResultsError, "profile YAML")
    data["name"] = "source_robot"
    data["description"] = "the source robot of tools.experiments.calibration_check"
    data["params"]["lidar"] = SOURCE_LIDAR
    source_profile = out / "source_robot.yaml"
    source_profile.write_text(yaml.safe_dump(data, sort_keys=False))
    record = ("record", "--world", world, "--method", method, "--time-limit", time_limit)
    _run(
        *record,
        "--noise",
        source_profile,
        "--seed",
        seeds[0],
        "--out",
        out / "source",
        "--overwrite",
    )
    calibrated = out / "calibrated.yaml"
    summary = parse_json(
        _run("calibrate", out / "source", "--out", calibrated, "--base", base, "--json"),
        ResultsError,
        "d3dwa calibrate --json",
    )
    figures: dict[str, Any] = {}
    for name, profile in (("calibrated", calibrated), ("base", base)):
        bag = out / f"sim_{name}"
        _run(*record, "--noise", profile, "--seed", seeds[1], "--out", bag, "--overwrite")
        result = parse_json(
            _run("compare-scans", out / "source", bag, "--json"), ResultsError, "compare-scans"
        )
        figures.setdefault("source", _figures(result["a"]))
        figures[name] = _figures(result["b"])
    keys = ("valid", *READING_CLASSES, "noise_mm")
    distance = {
        name: {k: _distance(figures["source"], figures[name], k) for k in keys}
        for name in ("calibrated", "base")
    }
    cal = load_profile(calibrated).sample(np.random.default_rng(0)).lidar
    return {
        "world": world,
        "method": method,
        "base": base,
        "commands": [
            f"d3dwa record --world {world} --method {method} --time-limit {time_limit} "
            f"--noise {source_profile} --seed {seeds[0]} --out {out / 'source'}",
            f"d3dwa calibrate {out / 'source'} --out {calibrated} --base {base}",
            f"d3dwa record ... --noise {calibrated} | {base} --seed {seeds[1]}",
            f"d3dwa compare-scans {out / 'source'} {out / 'sim_calibrated'} (and sim_base)",
        ],
        "calibrate": summary,
        "source_lidar": SOURCE_LIDAR,
        "calibrated_lidar": {
            "range_std": cal.range_std,
            "dropout_prob": cal.dropout_prob,
            "dropout_sector_scale": cal.dropout_sector_scale,
            "spurious_prob": cal.spurious_prob,
        },
        "sectors": figures,
        "mean_abs_difference_to_source": distance,
        "calibrated_closer": {k: distance["calibrated"][k] < distance["base"][k] for k in keys},
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="H1")
    ap.add_argument("--method", default="dwa3")
    ap.add_argument("--base", default="real")
    ap.add_argument("--time-limit", type=float, default=15.0)
    ap.add_argument("--out", type=Path, help="folder for the bags and profiles (default: temp)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        result = check(out, args.world, args.method, args.base, args.time_limit, (11, 12))
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    d = result["mean_abs_difference_to_source"]
    print(f"{result['world']} / {result['method']}: mean |sim - source| over 8 sectors")
    for k in d["calibrated"]:
        print(f"  {k:13s} calibrated {d['calibrated'][k]:.4f}  base {d['base'][k]:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
