"""Noise sweep of every method that can run, then its report page.

Thin wrapper around ``d3dwa sweep`` (same options; see ``d3dwa sweep --help``) that also
writes ``<out>/report.md``. Methods default to the fixed baselines plus each learned
method whose policy exists in ``policies/``.

    python scripts/noise_sweep.py --out results/sweep --levels 4 --layouts 3 --seeds 3
    python scripts/noise_sweep.py --out results/sweep --ray 10.0.0.5:6379
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from d3dwa_bullet.cli.app import main as d3dwa


def run(argv: Sequence[str]) -> int:
    """``d3dwa sweep ARGV`` then ``d3dwa report OUT``; the exit status of the first failure."""
    argv = list(argv)
    if "--out" not in argv:
        argv += ["--out", "results/sweep"]
    status = d3dwa(["sweep", *argv])
    if status != 0:
        return status
    return d3dwa(["report", argv[argv.index("--out") + 1]])


if __name__ == "__main__":
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(__doc__)
        d3dwa(["sweep", "--help"])  # prints the options and exits
    sys.exit(run(sys.argv[1:]))
