"""Count the episodes a ``d3dwa eval`` or ``d3dwa sweep`` command runs, without running one.

The command is parsed and checked as ``d3dwa`` would, its jobs built, and counted twice: every
(world, method, training seed, evaluation seed, noise) listed, and what runs since a fixed
method or a greedy policy without noise runs once per layout (d3dwa_bullet.evaluation.repeats).
Nothing is written but a scratch directory that is removed.

    python -m tools.bench.episode_count eval --methods dwa1,dwa2,dwa3 --worlds R1,R2,R3 --seeds 3
    python -m tools.bench.episode_count sweep --axes '' --layouts 10 --seeds 3 --methods dwa3,d3dwa

prints {"command", "listed", "run", "saved", "by_method": {method: [listed, run]}} as JSON.
"""

from __future__ import annotations

import argparse
import json
import shlex
import tempfile
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.cli.app import build_parser
from d3dwa_bullet.evaluation import jobs as evaluation
from d3dwa_bullet.evaluation import sweep
from d3dwa_bullet.evaluation.repeats import kept_keys
from tools.entry import ToolParser, fail, tool_main


class _Counted(Exception):
    """Raised in place of running the episodes: carries the jobs' keys."""

    def __init__(self, keys: list[Any]) -> None:
        super().__init__("counted")
        self.keys = keys


def _count(jobs: Sequence[evaluation.Job], *args: Any, **kwargs: Any) -> list[Any]:
    raise _Counted(list(dict.fromkeys(j.key for j in jobs)))


def count(argv: Sequence[str]) -> dict[str, Any]:
    """The counts of one eval or sweep command line (its words after ``d3dwa``)."""
    if not argv or argv[0] not in ("eval", "sweep"):
        fail("episode_count", f"{argv[:1]}: give a d3dwa eval or sweep command")
    if "--out" in argv:
        fail("episode_count", "leave out --out: nothing is written")
    with tempfile.TemporaryDirectory() as scratch:
        args = build_parser().parse_args([*argv, "--out", str(Path(scratch) / "out")])
        saved = evaluation.evaluate, sweep.evaluate
        evaluation.evaluate = sweep.evaluate = _count  # type: ignore[assignment]
        try:
            args.func(args)
        except _Counted as counted:
            keys = counted.keys
        else:
            fail("episode_count", "the command built no episodes")
        finally:
            evaluation.evaluate, sweep.evaluate = saved
    kept = kept_keys(keys)
    listed_by, run_by = Counter(k[1] for k in keys), Counter(k[1] for k in kept)
    return {
        "command": "d3dwa " + shlex.join(argv),
        "listed": len(keys),
        "run": len(kept),
        "saved": len(keys) - len(kept),
        "by_method": {m: [n, run_by[m]] for m, n in listed_by.items()},
    }


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=("eval", "sweep"), help="the d3dwa command to count")
    ap.add_argument("options", nargs=argparse.REMAINDER, help="its options, as d3dwa takes them")
    args = ap.parse_args(argv)
    print(json.dumps(count([args.command, *args.options])))


if __name__ == "__main__":
    raise SystemExit(main())
