"""The shipped worlds by name and group, and loading any world file by its type.

The shipped worlds are the native YAML files of ``worlds/``
(:func:`~d3dwa_bullet.resources.worlds_dir`). Their group is each file's ``group:`` field,
and they are listed (by ``d3dwa worlds``, in tables and figures) in a stable order, by the
key

    (group in the order train, unseen, real, custom;  the file's ``order:``;  file name)

a file without ``order:`` coming after those with one in its group. The shipped files give
TS1..TS4 (train), US1, H1..H3 (unseen), R1..R3 (real).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import UnknownNameError, WorldFormatError, did_you_mean
from d3dwa_bullet.resources import worlds_dir
from d3dwa_bullet.world.barn import barn_world_from_name
from d3dwa_bullet.world.barn_style import barn_style_world_from_name
from d3dwa_bullet.world.generator import generated_world_from_name
from d3dwa_bullet.world.map_server import load_map_world
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.native import (
    GROUPS,
    read_world_yaml,
    world_from_dict,
    world_group,
    world_order,
)
from d3dwa_bullet.world.sdf import load_sdf_world


def load_world_file(path: str | Path) -> World:
    """Load a native YAML world, a Gazebo SDF .world/.sdf, or a map_server .yaml map.

    The type is the suffix, and for .yaml whether the mapping has an ``image`` key (a
    map_server map) or not (the native format).
    """
    path = Path(path)
    kind, data = _kind_and_yaml(path)
    if kind == "sdf":
        return load_sdf_world(path)
    if kind == "map_server":
        return load_map_world(path)
    return world_from_dict(data, str(path))


def world_file_kind(path: str | Path) -> str:
    """How :func:`load_world_file` reads path: "sdf", "map_server" or "native" (by suffix,
    and for .yaml by whether the mapping has an ``image`` key); WorldFormatError if none."""
    return _kind_and_yaml(Path(path))[0]


def _kind_and_yaml(path: Path) -> tuple[str, Any]:
    """(kind of world file, its parsed YAML or None for an SDF file)."""
    if not path.is_file():
        raise WorldFormatError(f"{path}: no such world file")
    suffix = path.suffix.lower()
    if suffix in (".world", ".sdf"):
        return "sdf", None
    if suffix not in (".yaml", ".yml"):
        raise WorldFormatError(f"{path}: unknown world file type {suffix!r} (.yaml, .world, .sdf)")
    data = read_world_yaml(path)
    return ("map_server" if isinstance(data, Mapping) and "image" in data else "native"), data


@cache
def _shipped(directory: Path) -> tuple[tuple[str, str, Path], ...]:
    """(name, group, path) of every native world in ``directory``, in listing order.

    Cached: the shipped files do not change while a process runs.
    """
    rows = []
    for path in sorted(directory.glob("*.yaml")):
        data = read_world_yaml(path)
        if not isinstance(data, Mapping):
            raise WorldFormatError(
                f"{path}: top level must be a mapping, got {type(data).__name__}"
            )
        group, order = world_group(data, str(path)), world_order(data, str(path))
        key = (GROUPS.index(group), math.inf if order is None else order, path.stem)
        rows.append((key, path.stem, group, path))
    return tuple((name, group, path) for _, name, group, path in sorted(rows))


def world_paths() -> dict[str, Path]:
    """Shipped native worlds by name, in listing order (TS1..TS4, US1, H1..H3, R1..R3)."""
    return {name: path for name, _, path in _shipped(worlds_dir())}


def world_names(*groups: str) -> tuple[str, ...]:
    """Names of the shipped worlds in any of ``groups`` (all if none), in listing order.

    ``world_names("train")`` are the training worlds; ``world_names("train", "unseen")``
    the worlds of Table I, ``world_names("real")`` those of Table II.
    """
    for g in groups:
        if g not in GROUPS:
            raise UnknownNameError(f"unknown world group {g!r}: choose from {', '.join(GROUPS)}")
    return tuple(name for name, group, _ in _shipped(worlds_dir()) if not groups or group in groups)


def world_groups() -> dict[str, str]:
    """The group of every shipped world, by name, in listing order."""
    return {name: group for name, group, _ in _shipped(worlds_dir())}


def list_worlds() -> list[World]:
    """Every shipped world, loaded, in listing order."""
    return [load_world_file(p) for p in world_paths().values()]


def load_world(name_or_path: str | Path) -> World:
    """A shipped world by name (case-insensitive), a BARN world by name (BARN-17), a
    generated layout by name (such as R2-style-s17 or BARN-style-s2147483648) or any world file by path."""
    text = str(name_or_path)
    paths = world_paths()
    by_upper = {n.upper(): p for n, p in paths.items()}
    if text.upper() in by_upper:
        return load_world_file(by_upper[text.upper()])
    if Path(text).suffix:
        return load_world_file(text)
    barn = barn_world_from_name(text)
    if barn is not None:
        return barn
    generated = generated_world_from_name(text)
    if generated is not None:
        return generated
    barn_style = barn_style_world_from_name(text)
    if barn_style is not None:
        return barn_style
    raise UnknownNameError(
        f"unknown world {text!r}: {did_you_mean(text, paths)}choose one of {', '.join(paths)}, a BARN "
        "world such as BARN-17, a generated layout such as R2-style-s17 or BARN-style-s2147483648, or a "
        "path to a world file"
    )
