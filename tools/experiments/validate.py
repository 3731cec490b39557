"""The 25-case validation on training material: greedy successes of policies, no noise.

    python -m tools.experiments.validate policies/d3dwa runs/d3dwa/policy --json

Worlds: TS1-TS4 plus 21 generated layouts (R1-style-s2..s8, R2-style-s3..s9,
R3-style-s3..s9): training material (the trainings see those styles, never these
layouts as such, nor US1, H1-H3 or the R1-R3 files), one noise-free episode each (seed 0).
This is the validation the single-seed policies were chosen by (docs/history.md); it is a
developer instrument, not a results table.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from d3dwa_bullet.cli.app import main as d3dwa
from d3dwa_bullet.evaluation.results import read_results
from tools.entry import ToolParser, tool_main

VALIDATION_WORLDS = (
    ("TS1", "TS2", "TS3", "TS4")
    + tuple(f"R1-style-s{k}" for k in range(2, 9))
    + tuple(f"R2-style-s{k}" for k in range(3, 10))
    + tuple(f"R3-style-s{k}" for k in range(3, 10))
)


def run(policy: str | Path, method: str = "d3dwa", workers: int | None = None) -> dict:
    """Successes of one policy directory on the 25 validation cases."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "validation"
        argv = ["eval", "--methods", method, "--policy", str(policy), "--worlds",
                ",".join(VALIDATION_WORLDS), "--seeds", "1", "--out", str(out),
                "--json", *(["--workers", str(workers)] if workers is not None else [])]  # fmt: skip
        with contextlib.redirect_stdout(io.StringIO()):  # the rows, as JSON: not ours to print
            code = d3dwa(argv)
        if code != 0:
            raise SystemExit(code)
        rows = read_results(out)
    outcomes = {r["world"]: r["outcome"] for r in rows}
    return {
        "policy": str(policy),
        "successes": sum(o == "goal" for o in outcomes.values()),
        "cases": len(VALIDATION_WORLDS),
        "failed": sorted(w for w, o in outcomes.items() if o != "goal"),
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    ap = ToolParser(description=__doc__.splitlines()[0])
    ap.add_argument("policies", nargs="+", help="policy directories (weights.pt + meta.json)")
    ap.add_argument("--method", default="d3dwa", help="the method the policies are of")
    ap.add_argument("--workers", type=int, help="local processes (default: all cores)")
    ap.add_argument("--json", action="store_true", help="one JSON object per policy")
    args = ap.parse_args(argv)
    for policy in args.policies:
        result = run(policy, args.method, args.workers)
        if args.json:
            print(json.dumps(result))
        else:
            print(f"{policy}: {result['successes']}/{result['cases']}  failed: "
                  f"{', '.join(result['failed']) or '-'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
