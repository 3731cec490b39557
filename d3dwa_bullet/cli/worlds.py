"""``d3dwa worlds``: list the shipped worlds (name, group, goal, description), or a suite's
worlds with their split and difficulty (``--suite barn``)."""

from __future__ import annotations

import argparse

from d3dwa_bullet.cli.output import json_text
from d3dwa_bullet.cli.suites import add_suite_options, suite_list, suite_world_names
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.barn import barn_index, barn_split, path_length, read_world_file, world_file
from d3dwa_bullet.world.barn_difficulty import (
    TERCILE_MEASURE,
    barn_difficulty,
    barn_tercile,
    difficulty_of,
)
from d3dwa_bullet.world.barn_style import barn_style_draw, barn_style_seed
from d3dwa_bullet.world.registry import list_worlds


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "worlds", help="list the shipped worlds, or a suite's (--suite barn, barn-style)"
    )
    p.add_argument("--json", action="store_true")
    add_suite_options(p)
    p.set_defaults(func=cmd_worlds, worlds=None)


def cmd_worlds(args: argparse.Namespace) -> int:
    suite = suite_world_names(args, default_split="all")
    suites = suite_list(args.suite) if suite is not None else []
    if len(suites) > 1:  # two tables of other columns
        raise ConfigError(f"worlds --suite {args.suite}: list one suite at a time")
    if suites == ["barn-style"]:
        return _list_barn_style(suite, args.json)
    if suite is not None:
        return _list_suite(suite, args.json)
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


def _list_suite(names: list[str], as_json: bool) -> int:
    """One row per BARN world: id, split, tercile, the difficulty measures, path length."""
    records = []
    for name in names:
        i = int(barn_index(name))  # type: ignore[arg-type]  # names come from the suite
        records.append(
            {"name": name, "id": i, "split": barn_split(i), "tercile": barn_tercile(i)}
            | barn_difficulty(i).to_dict()
            | {"reference_length": path_length(read_world_file(world_file(i))[1])}
        )
    if as_json:
        print(json_text(records))
        return 0
    print(f"tercile by {TERCILE_MEASURE}; clearance and width in m, path length in m")
    print("name      id   split      tercile  clear_mean  clear_min  char_dim  tortuosity  path")
    for r in records:
        print(
            f"{r['name']:<9} {r['id']:>3}  {r['split']:<9}  {r['tercile']:<7}  "
            f"{r['clearance_mean']:>10.3f}  {r['clearance_min']:>9.3f}  "
            f"{r['characteristic_dimension']:>8.3f}  {r['tortuosity']:>10.3f}  "
            f"{r['reference_length']:>5.2f}"
        )
    return 0


def _list_barn_style(names: list[str], as_json: bool) -> int:
    """One row per BARN-style world: seed, recipe setting, the difficulty measures, path length."""
    records = []
    for name in names:
        d = barn_style_draw(int(barn_style_seed(name)))  # type: ignore[arg-type]  # suite names
        records.append(
            {"name": name, "seed": d.seed, "fill": d.fill, "passes": d.passes}
            | difficulty_of(d.grid, d.path).to_dict()
            | {"reference_length": path_length(d.path)}
        )
    if as_json:
        print(json_text(records))
        return 0
    print(
        "BARN-style worlds (BARN's recipe, not BARN's worlds); clearance and width in m, path length in m"
    )
    print(f"{'name':<24} fill  passes  clear_mean  clear_min  char_dim  tortuosity  path")
    for r in records:
        print(
            f"{r['name']:<24} {r['fill']:.2f}  {r['passes']:>6}  {r['clearance_mean']:>10.3f}  "
            f"{r['clearance_min']:>9.3f}  {r['characteristic_dimension']:>8.3f}  "
            f"{r['tortuosity']:>10.3f}  {r['reference_length']:>5.2f}"
        )
    return 0
