"""The native world format: one YAML file per world (``worlds/*.yaml``).

::

    name: TS1                     # required
    group: train                  # train | unseen | real | custom (default custom)
    order: 1                      # optional: place in listings and tables within the group
    description: mostly open ...  # required, one line
    start: [0.0, 0.0, 0.0]        # x, y (m), yaw (rad)
    goal: [3.5, 0.5]              # x, y (m)
    time_limit: 60.0              # optional, s
    obstacles:                    # boxes, cylinders and wall segments
      - {type: box, center: [1.0, 0.2], size: [0.4, 0.3], yaw: 0.0, height: 0.5}
      - {type: cylinder, center: [2.0, -0.3], radius: 0.15, height: 0.5}
      - {type: wall, start: [-1, 1], end: [5, 1], thickness: 0.1, height: 0.5}

``yaw`` and ``height`` are optional (defaults 0 rad and 0.5 m). A wall is a box from
``start`` to ``end`` extended by half its thickness at each end, so walls meet at corners.
Unknown keys are errors (a typo must not silently drop obstacles). ``group`` and ``order``
are what :mod:`~d3dwa_bullet.world.registry` lists the shipped worlds by.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.world.barn import SPLIT_GROUPS as BARN_GROUPS
from d3dwa_bullet.world.fields import positive, required, vector
from d3dwa_bullet.world.model import DEFAULT_HEIGHT, Box, Cylinder, Obstacle, World, validate_task

GROUPS = ("train", "unseen", "real", "custom")
"""World groups, in the order listings and tables print them."""
EVAL_ONLY_GROUPS = ("unseen", "real", BARN_GROUPS["challenge"])
"""Groups for evaluation only: training never runs on their worlds (BARN's challenge split
included)."""
WORLD_KEYS = {"name", "group", "order", "description", "start", "goal", "time_limit", "obstacles"}
OBSTACLE_KEYS = {
    "box": {"type", "center", "size", "yaw", "height"},
    "cylinder": {"type", "center", "radius", "height"},
    "wall": {"type", "start", "end", "thickness", "height"},
}


def read_world_yaml(path: Path) -> Any:
    """The parsed content of a YAML world file, or WorldFormatError if it is not YAML."""
    return load_yaml(path, WorldFormatError, "world file")


def world_group(data: Mapping[str, Any], source: str) -> str:
    """The file's ``group`` (default "custom"), checked against GROUPS."""
    group = str(data.get("group", "custom"))
    if group not in GROUPS:
        raise WorldFormatError(f"{source}: field 'group' = {group!r} is not one of {GROUPS}")
    return group


def world_order(data: Mapping[str, Any], source: str) -> int | None:
    """The file's ``order`` (an integer >= 0), or None when it has none."""
    order = data.get("order")
    if order is not None and (isinstance(order, bool) or not isinstance(order, int) or order < 0):
        raise WorldFormatError(f"{source}: field 'order' must be an integer >= 0, got {order!r}")
    return order


def parse_obstacle(spec: Any, where: str) -> Obstacle:
    """One obstacle entry of the native format."""
    if not isinstance(spec, Mapping):
        raise WorldFormatError(f"{where}: must be a mapping, got {spec!r}")
    kind = required(spec, "type", where)
    allowed = OBSTACLE_KEYS.get(kind)
    if allowed is not None and set(spec) - allowed:
        raise WorldFormatError(
            f"{where}: unknown field(s) {sorted(set(spec) - allowed)} for a {kind}"
        )
    height = positive(spec.get("height", DEFAULT_HEIGHT), where, "height")
    if kind == "box":
        size = vector(required(spec, "size", where), 2, where, "size")
        for v in size:
            positive(v, where, "size")
        return Box(
            center=vector(required(spec, "center", where), 2, where, "center"),  # type: ignore[arg-type]
            size=size,  # type: ignore[arg-type]
            yaw=vector([spec.get("yaw", 0.0)], 1, where, "yaw")[0],
            height=height,
        )
    if kind == "cylinder":
        return Cylinder(
            center=vector(required(spec, "center", where), 2, where, "center"),  # type: ignore[arg-type]
            radius=positive(required(spec, "radius", where), where, "radius"),
            height=height,
        )
    if kind == "wall":
        a = np.array(vector(required(spec, "start", where), 2, where, "start"))
        b = np.array(vector(required(spec, "end", where), 2, where, "end"))
        thickness = positive(spec.get("thickness", 0.1), where, "thickness")
        length = float(np.hypot(*(b - a)))
        if length <= 0:
            raise WorldFormatError(f"{where}: wall 'start' and 'end' coincide at {a.tolist()}")
        mid = 0.5 * (a + b)
        return Box(
            center=(float(mid[0]), float(mid[1])),
            size=(length + thickness, thickness),
            yaw=float(math.atan2(b[1] - a[1], b[0] - a[0])),
            height=height,
        )
    raise WorldFormatError(
        f"{where}: field 'type' = {kind!r} is not a known shape (box, cylinder, wall)"
    )


def world_from_dict(data: Any, source: str) -> World:
    """Build and validate a World from the native format's mapping."""
    if not isinstance(data, Mapping):
        raise WorldFormatError(f"{source}: top level must be a mapping, got {type(data).__name__}")
    unknown = set(data) - WORLD_KEYS
    if unknown:
        raise WorldFormatError(
            f"{source}: unknown field(s) {sorted(unknown)}; allowed: {sorted(WORLD_KEYS)}"
        )
    group = world_group(data, source)
    world_order(data, source)
    obstacles = data.get("obstacles", []) or []
    if not isinstance(obstacles, list):
        raise WorldFormatError(f"{source}: field 'obstacles' must be a list, got {obstacles!r}")
    time_limit = data.get("time_limit")
    world = World(
        name=str(required(data, "name", source)),
        description=str(required(data, "description", source)),
        start=vector(required(data, "start", source), 3, source, "start"),  # type: ignore[arg-type]
        goal=vector(required(data, "goal", source), 2, source, "goal"),  # type: ignore[arg-type]
        obstacles=tuple(
            parse_obstacle(spec, f"{source}: obstacles[{i}]") for i, spec in enumerate(obstacles)
        ),
        group=group,
        time_limit=None if time_limit is None else positive(time_limit, source, "time_limit"),
        source=source,
    )
    validate_task(world)
    return world
