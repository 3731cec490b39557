"""``d3dwa report DIR``: one Markdown page (tables and figures) for a results directory."""

from __future__ import annotations

import argparse
import os
import sys

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="one Markdown page (tables + figures) for a results dir")
    p.add_argument("dir", help="a results directory written by `d3dwa eval` or `d3dwa sweep`")
    p.add_argument(
        "--policies",
        help="where learning curves live (default: the --policy an evaluation ran, else the "
        "shipped policies/)",
    )
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_report)


def cmd_report(args: argparse.Namespace) -> int:
    # start-up cost: the report imports the evaluation (pybullet, matplotlib)
    from d3dwa_bullet.evaluation.report import write_report

    if os.path.isdir(args.dir) and not os.access(args.dir, os.W_OK | os.X_OK):
        raise ConfigError(f"{args.dir}: cannot write report.md in it (permission denied)")
    if not os.path.isdir(args.dir):  # write_report names what is missing
        report = write_report(args.dir, args.policies)
    else:
        with locked_dir(args.dir, "DIR"):  # not while an eval or sweep still writes it
            report = write_report(args.dir, args.policies)
    if args.json:
        print(json_text({"report": str(report.path), "kind": report.kind,
                          "complete": report.complete, "done": report.done,
                          "expected": report.expected}))  # fmt: skip
    else:
        print(f"report: {report.path}")
    if not report.complete:
        print(
            f"d3dwa: warning: {args.dir} is incomplete ({report.done} of {report.expected} "
            "episodes); the page says so",
            file=sys.stderr,
        )
    return 0
