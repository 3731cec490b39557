"""``d3dwa replay``, ``d3dwa record``, ``d3dwa compare-scans``: the bag commands' parsers,
wired to their implementations in :mod:`d3dwa_bullet.cli.transfer` with the simulator side
(:mod:`transfer.sim_bridge`) passed in."""

from __future__ import annotations

import argparse

from d3dwa_bullet.cli.transfer import (
    add_compare_arguments,
    add_record_arguments,
    add_replay_arguments,
    run_compare,
    run_record,
    run_replay,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the parsers of the three bag commands."""
    p = sub.add_parser(
        "replay", help="replay a ROS bag through the observation pipeline and a method"
    )
    add_replay_arguments(p)
    p.set_defaults(func=cmd_replay)
    p = sub.add_parser("record", help="record a simulated episode as a ROS 2 bag")
    add_record_arguments(p)
    p.set_defaults(func=cmd_record)
    p = sub.add_parser("compare-scans", help="per-sector scan statistics of two bags")
    add_compare_arguments(p)
    p.set_defaults(func=cmd_compare)


def cmd_replay(args: argparse.Namespace) -> int:
    # start-up cost: transfer.sim_bridge imports the simulator (pybullet)
    from transfer.sim_bridge import make_step_fn

    return run_replay(args, make_step_fn=make_step_fn)


def cmd_record(args: argparse.Namespace) -> int:
    # start-up cost: transfer.sim_bridge imports the simulator (pybullet)
    from transfer.sim_bridge import record_episode

    return run_record(args, record_episode)


def cmd_compare(args: argparse.Namespace) -> int:
    return run_compare(args)
