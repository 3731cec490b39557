"""Replay a ROS bag (a real Kachaka's, or one `d3dwa record` wrote) through D3DWA.

Thin wrapper around ``d3dwa replay`` (same options; see ``d3dwa replay --help``) that
only changes two defaults: ``--method d3dwa`` (the shipped policy, unless ``--policy``
names another checkpoint) instead of observations only, and ``--out results/replay``.
Writes ``replay.csv``, ``summary.json`` and the figures into the output directory.

    python scripts/replay_bag.py kachaka_run.bag
    python scripts/replay_bag.py runs/r2_bag --method dwa2 --estimator ekf --out results/r2
    python scripts/replay_bag.py kachaka_run.bag --goal 3.0,0.5 --topic scan=/scan --json
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from d3dwa_bullet.cli import main as d3dwa

DEFAULTS = {"--method": "d3dwa", "--out": "results/replay"}


def given(argv: Sequence[str], option: str) -> bool:
    """Whether argv sets option, as ``--out DIR`` or ``--out=DIR``."""
    return any(a == option or a.startswith(option + "=") for a in argv)


def run(argv: Sequence[str]) -> int:
    """``d3dwa replay ARGV`` with this script's defaults; its exit status."""
    argv = list(argv)
    for option, value in DEFAULTS.items():
        if not given(argv, option):
            argv += [option, value]
    return d3dwa(["replay", *argv])


if __name__ == "__main__":
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(__doc__)
        d3dwa(["replay", "--help"])  # prints the options and exits
    sys.exit(run(sys.argv[1:]))
