"""``d3dwa worlds``: list the shipped worlds (name, group, goal, description)."""

from __future__ import annotations

import argparse

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.world.registry import list_worlds


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("worlds", help="list the shipped worlds")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_worlds)


def cmd_worlds(args: argparse.Namespace) -> int:
    worlds = list_worlds()
    if args.json:
        print(json_text([{"name": w.name, "group": w.group, "description": w.description,
                           "goal": list(w.goal), "obstacles": len(w.obstacles)} for w in worlds]))  # fmt: skip
        return 0
    width = max(len(w.name) for w in worlds)
    for w in worlds:
        print(
            f"{w.name:<{width}}  {w.group:<7} goal ({w.goal[0]:.2f}, {w.goal[1]:.2f})  {w.description}"
        )
    return 0
