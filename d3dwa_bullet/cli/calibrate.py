"""``d3dwa calibrate BAG [BAG ...] --out my_robot.yaml``: fit a randomisation profile to a
robot's own bags (:mod:`transfer.calibration`). The profile loads with ``--noise`` and in a
training config's ``noise:`` list; ``--json`` prints what was estimated and what kept.

Bad input (no LaserScan, too few scans, an unreadable bag, a bad ``--out``) ends in one
``d3dwa: error: ...`` line and exit 2, and no profile file: it is written atomically at
the end. An existing ``--out`` is replaced only if calibrate wrote it, or with ``--force``
(a training config named by mistake stays as it was). A robot that never stands still is not an error: the range noise then comes from
line-fit residuals, and a note says so.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from d3dwa_bullet.cli.options import parse_floats
from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.cli.transfer import parse_topic_overrides
from d3dwa_bullet.sim.scan import Pose2D


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate", help="fit a randomisation profile (lidar, odometry, gyro) to ROS bags"
    )
    p.add_argument("bags", type=Path, nargs="+", metavar="BAG", help="ROS 1 or ROS 2 bags")
    p.add_argument("--out", type=Path, required=True, help="profile file to write (.yaml)")
    p.add_argument(
        "--base", default="real",
        help="profile whose values the bags cannot inform are kept (default: real)",
    )  # fmt: skip
    p.add_argument(
        "--force", action="store_true",
        help="replace --out even if it is not a profile written by calibrate",
    )  # fmt: skip
    p.add_argument("--name", help="profile name (default: the --out file's stem)")
    p.add_argument("--mount", help="X,Y,YAW lidar pose in base_link (default: from tf)")
    p.add_argument(
        "--topic", action="append", metavar="ROLE=NAME",
        help="override a topic (scan, odometry = the reference, wheel_odometry, imu, ...); "
        "ROLE= disables it",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args: argparse.Namespace, out: TextIO | None = None) -> int:
    # start-up cost: the fits import scipy.optimize and scipy.stats (~0.3 s)
    from transfer.calibration import calibrate

    out = sys.stdout if out is None else out
    mount = Pose2D(*parse_floats(args.mount, 3, "--mount")) if args.mount else None
    result = calibrate(
        args.bags, args.out, base=args.base, name=args.name,
        topics=parse_topic_overrides(args.topic), mount=mount, force=args.force,
    )  # fmt: skip
    notes = sys.stderr if args.json else out
    for note in result.notes:
        notes.write(f"note: {note}\n")
    if args.json:
        out.write(json_text(result.summary(), indent=2) + "\n")
        return 0
    out.write(f"wrote {result.profile} ({result.scans} scans from {len(args.bags)} bag(s))\n")
    out.write(f"estimated: {', '.join(result.estimated)}\n")
    out.write(f"kept from base {args.base!r}: {', '.join(result.kept_from_base) or 'none'}\n")
    out.write(f"use it with: --noise {result.profile}\n")
    return 0
