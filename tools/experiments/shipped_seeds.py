"""The shipped training seeds: one row per method from every ``policies/<method>/seed-<k>/``.

Reads each seed's ``summary.json`` (what its training run measured) and prints a Markdown
table (or ``--json``): seeds, control steps, the step kept (per seed: the best validation's
under ``keep: best``, the last under ``keep: final``, as the seed's config.json says), that
checkpoint's validation success on the config's eval_worlds, its value ratio there (mean Q of
the visited (s, a) over the discounted return they earned; ``gap`` and the absolute difference
where the return is under 0.1; ``--`` for seeds trained before values were logged), and the
wall time per seed. A policy that decides every ``decision_steps`` control steps counts its
steps in control steps too. Nothing here is typed in; the README's policy table is this
command's output.

    python -m tools.experiments.shipped_seeds
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.learning.agents.policy_terms import (
    DEFAULT_DECISION_STEPS,
    decision_period,
    folder_terms,
)
from d3dwa_bullet.learning.value_calibration import ValueCalibration
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.method_specs import LEARNED
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.seed_dirs import kept_evaluation, seed_dirs
from tools.entry import ToolParser, tool_main


def seed_records(folder: Path) -> list[dict[str, Any]]:
    """Per method with seed folders: its seeds and their training figures."""
    out = []
    for method in LEARNED:
        seeds = seed_dirs(folder / method)
        if not seeds:
            continue
        rows = []
        for k, path in seeds.items():
            summary = _summary(path / "summary.json")
            keep, kept = kept_evaluation(path, summary)
            per = seed_decision_steps(path)
            step = kept.get("step")
            rows.append({
                "seed": k, "env_steps": summary["env_steps"] * per, "keep": keep,
                "kept_step": None if step is None else step * per,
                "validation_success": kept.get("success_rate"),
                "values": kept.get("values"), "wall_min": summary["wall_time_s"] / 60.0,
            })  # fmt: skip
        out.append({"method": method, "seeds": rows})
    return out


def _summary(path: Path) -> dict[str, Any]:
    """A seed's summary.json: ResultsError (one line naming file and field) unless it is an
    object whose ``env_steps`` and ``wall_time_s`` are finite numbers >= 0."""
    summary = load_json(path, ResultsError, "training summary.json")
    if not isinstance(summary, dict):
        raise ResultsError(f"{path}: expected a JSON object, got {type(summary).__name__}")
    for key in ("env_steps", "wall_time_s"):
        value = summary.get(key)
        if not (isinstance(value, int | float) and not isinstance(value, bool)) or not (
            math.isfinite(value) and value >= 0
        ):
            raise ResultsError(f"{path}: {key} is {value!r}, expected a number >= 0")
    return summary


def seed_decision_steps(folder: Path) -> int:
    """Control steps per decision of one seed folder: the period its meta.json records,
    checked against its config.json (``policy_terms.folder_terms``), or its config.json's
    alone without a meta.json; 1 without either. CheckpointError (one line) for a bad one."""
    if (folder / "meta.json").is_file():
        return int(folder_terms(folder)["decision_steps"])  # type: ignore[call-overload]
    config = folder / "config.json"
    data = load_json(config, ResultsError) if config.is_file() else {}
    if not isinstance(data, dict):
        raise ResultsError(f"{config}: expected a JSON object, got {type(data).__name__}")
    value = data.get("decision_steps", DEFAULT_DECISION_STEPS)
    return decision_period(value, f"{config}: decision_steps")


def _value_text(values: dict[str, Any] | None) -> str:
    """The figure the calibration rule judges (``ValueCalibration.judged_by``)."""
    if not values:
        return "--"
    c = ValueCalibration(
        values["mean_q"], values["mean_return"], values.get("pairs", 0), values.get("episodes", 0)
    )
    return f"gap {c.gap:+.3f}" if c.judged_by == "gap" else f"{c.ratio:.2f}"


def markdown(records: Sequence[dict[str, Any]]) -> str:
    lines = [
        "| policy | seeds | env steps | step kept (per seed) | validation success (per seed) "
        "| value ratio (per seed) | wall per seed |",
        "|---|---:|---:|---|---|---|---|",
    ]
    for r in records:
        s = r["seeds"]
        steps = {x["env_steps"] for x in s}
        kept = ", ".join(f"{x['kept_step'] // 1000}k" if x["kept_step"] else "final" for x in s)
        val = ", ".join(
            f"{x['validation_success']:.2f}" if x["validation_success"] is not None else "--"
            for x in s
        )
        walls = [x["wall_min"] for x in s]
        lines.append(
            f"| `{r['method']}` | {', '.join(str(x['seed']) for x in s)} | "
            f"{'/'.join(f'{n // 1000}k' for n in sorted(steps))} | {kept} | {val} | "
            f"{', '.join(_value_text(x['values']) for x in s)} | "
            f"{min(walls):.1f}-{max(walls):.1f} min |"
        )
    return "\n".join(lines) + "\n"


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policies", help="policies folder (default: the shipped one)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    records = seed_records(Path(args.policies) if args.policies else policies_dir())
    print(json.dumps(records, indent=1) if args.json else markdown(records), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
