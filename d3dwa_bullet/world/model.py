"""Worlds: static obstacles, a start pose and a goal.

Native format (``worlds/*.yaml``)::

    name: TS1                     # required
    group: train                  # train | unseen | real | custom
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
Unknown keys are errors (a typo must not silently drop obstacles). Gazebo SDF ``.world`` files and ROS map_server maps (``.yaml`` with an
``image`` key) load into the same :class:`World`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from d3dwa_bullet.errors import UnknownNameError, WorldFormatError
from d3dwa_bullet.resources import worlds_dir

DEFAULT_HEIGHT = 0.5
GROUPS = ("train", "unseen", "real", "custom")
WORLD_KEYS = {"name", "group", "description", "start", "goal", "time_limit", "obstacles"}
OBSTACLE_KEYS = {
    "box": {"type", "center", "size", "yaw", "height"},
    "cylinder": {"type", "center", "radius", "height"},
    "wall": {"type", "start", "end", "thickness", "height"},
}
#: Kachaka's body box in base_link: centre x, half length, half width (SPEC section 3).
BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH = 0.0435, 0.1935, 0.120


@dataclass(frozen=True)
class Box:
    """An upright box obstacle. center (x, y) m, size (sx, sy) m, yaw rad, height m."""

    center: tuple[float, float]
    size: tuple[float, float]
    yaw: float = 0.0
    height: float = DEFAULT_HEIGHT


@dataclass(frozen=True)
class Cylinder:
    """An upright cylinder obstacle. center (x, y) m, radius m, height m."""

    center: tuple[float, float]
    radius: float
    height: float = DEFAULT_HEIGHT


Obstacle = Box | Cylinder


@dataclass(frozen=True)
class World:
    """A navigation case: obstacles, start pose (x, y, yaw) and goal (x, y)."""

    name: str
    description: str
    start: tuple[float, float, float]
    goal: tuple[float, float]
    obstacles: tuple[Obstacle, ...] = ()
    group: str = "custom"
    time_limit: float | None = None
    source: str = "<memory>"
    """Where the world came from (a path, or a generator description)."""

    def with_task(
        self,
        start: tuple[float, float, float] | None = None,
        goal: tuple[float, float] | None = None,
        time_limit: float | None = None,
    ) -> World:
        """A copy with another start, goal or time limit, re-validated."""
        w = replace(
            self,
            start=self.start if start is None else _vector(start, 3, self.source, "start"),
            goal=self.goal if goal is None else _vector(goal, 2, self.source, "goal"),
            time_limit=self.time_limit if time_limit is None else float(time_limit),
        )
        validate_task(w)
        return w

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance from points to the nearest obstacle surface (negative inside).

        points: (N, 2) float64, m, world frame. Returns (N,) float64, m (+inf if no obstacles).
        """
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        best = np.full(len(pts), np.inf)
        for ob in self.obstacles:
            best = np.minimum(best, obstacle_distance(ob, pts))
        return best

    def bounds(self, margin: float = 0.5) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) enclosing obstacles, start and goal, plus margin, m."""
        xs = [self.start[0], self.goal[0]]
        ys = [self.start[1], self.goal[1]]
        for ob in self.obstacles:
            if isinstance(ob, Cylinder):
                ext = (ob.radius, ob.radius)
            else:
                c, s = abs(math.cos(ob.yaw)), abs(math.sin(ob.yaw))
                ext = (
                    0.5 * (ob.size[0] * c + ob.size[1] * s),
                    0.5 * (ob.size[0] * s + ob.size[1] * c),
                )
            xs += [ob.center[0] - ext[0], ob.center[0] + ext[0]]
            ys += [ob.center[1] - ext[1], ob.center[1] + ext[1]]
        return min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin


def obstacle_distance(ob: Obstacle, pts: np.ndarray) -> np.ndarray:
    """Signed distance (N,) from (N, 2) points to one obstacle's footprint, m."""
    d = pts - np.asarray(ob.center, dtype=np.float64)
    if isinstance(ob, Cylinder):
        return np.hypot(d[:, 0], d[:, 1]) - ob.radius
    c, s = math.cos(ob.yaw), math.sin(ob.yaw)
    local = np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]))
    q = np.abs(local) - 0.5 * np.asarray(ob.size, dtype=np.float64)
    outside = np.hypot(np.maximum(q[:, 0], 0.0), np.maximum(q[:, 1], 0.0))
    inside = np.minimum(np.maximum(q[:, 0], q[:, 1]), 0.0)
    return outside + inside


def body_outline(poses: Sequence[float] | np.ndarray, samples_per_side: int = 8) -> np.ndarray:
    """Points on Kachaka's body rectangle at one pose (x, y, yaw) or at (N, 3) poses.

    Returns (4 * samples, 2) for one pose or (N, 4 * samples, 2) for N poses, m, world frame.
    """
    t = np.linspace(-1.0, 1.0, samples_per_side, endpoint=False)
    hl, hw = BODY_HALF_LENGTH, BODY_HALF_WIDTH
    local = np.concatenate(
        [
            np.column_stack((hl * t, np.full_like(t, -hw))),
            np.column_stack((np.full_like(t, hl), hw * t)),
            np.column_stack((-hl * t, np.full_like(t, hw))),
            np.column_stack((np.full_like(t, -hl), -hw * t)),
        ]
    )
    local[:, 0] += BODY_CENTER_X
    arr = np.asarray(poses, dtype=np.float64)
    many = arr.reshape(-1, 3)
    c, s = np.cos(many[:, 2])[:, None], np.sin(many[:, 2])[:, None]
    wx = many[:, 0:1] + c * local[:, 0] - s * local[:, 1]
    wy = many[:, 1:2] + s * local[:, 0] + c * local[:, 1]
    out = np.stack((wx, wy), axis=-1)
    return out[0] if arr.ndim == 1 else out


def validate_task(world: World) -> None:
    """Refuse a start pose in collision or a goal inside an obstacle."""
    if not all(math.isfinite(v) for v in (*world.start, *world.goal)):
        raise WorldFormatError(
            f"{world.source}: start {world.start} / goal {world.goal} must be finite"
        )
    if world.time_limit is not None and not world.time_limit > 0:
        raise WorldFormatError(
            f"{world.source}: field 'time_limit' must be > 0, got {world.time_limit!r}"
        )
    if not world.obstacles:
        return
    body = body_outline(world.start)
    inside_body = np.array(
        [obstacle_distance(ob, np.array([world.start[:2]]))[0] for ob in world.obstacles]
    )
    if (world.distance(body) <= 0.0).any() or (inside_body <= 0.0).any():
        raise WorldFormatError(
            f"{world.source}: field 'start' = {list(world.start)} puts the robot body in collision"
        )
    goal_d = float(world.distance(np.array([world.goal]))[0])
    if goal_d <= 0.0:
        raise WorldFormatError(
            f"{world.source}: field 'goal' = {list(world.goal)} lies inside an obstacle"
        )


def _field(data: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in data:
        raise WorldFormatError(f"{where}: missing field '{key}'")
    return data[key]


def _vector(value: Any, n: int, where: str, key: str) -> tuple[float, ...]:
    try:
        vec = tuple(float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise WorldFormatError(
            f"{where}: field '{key}' must be {n} numbers, got {value!r}"
        ) from err
    if len(vec) != n or not all(math.isfinite(v) for v in vec):
        raise WorldFormatError(f"{where}: field '{key}' must be {n} finite numbers, got {value!r}")
    return vec


def _positive(value: Any, where: str, key: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise WorldFormatError(f"{where}: field '{key}' must be a number, got {value!r}") from err
    if not (math.isfinite(v) and v > 0):
        raise WorldFormatError(f"{where}: field '{key}' must be > 0, got {value!r}")
    return v


def parse_obstacle(spec: Any, where: str) -> Obstacle:
    """One obstacle entry of the native format."""
    if not isinstance(spec, Mapping):
        raise WorldFormatError(f"{where}: must be a mapping, got {spec!r}")
    kind = _field(spec, "type", where)
    allowed = OBSTACLE_KEYS.get(kind)
    if allowed is not None and set(spec) - allowed:
        raise WorldFormatError(
            f"{where}: unknown field(s) {sorted(set(spec) - allowed)} for a {kind}"
        )
    height = _positive(spec.get("height", DEFAULT_HEIGHT), where, "height")
    if kind == "box":
        size = _vector(_field(spec, "size", where), 2, where, "size")
        for v in size:
            _positive(v, where, "size")
        return Box(
            center=_vector(_field(spec, "center", where), 2, where, "center"),  # type: ignore[arg-type]
            size=size,  # type: ignore[arg-type]
            yaw=_vector([spec.get("yaw", 0.0)], 1, where, "yaw")[0],
            height=height,
        )
    if kind == "cylinder":
        return Cylinder(
            center=_vector(_field(spec, "center", where), 2, where, "center"),  # type: ignore[arg-type]
            radius=_positive(_field(spec, "radius", where), where, "radius"),
            height=height,
        )
    if kind == "wall":
        a = np.array(_vector(_field(spec, "start", where), 2, where, "start"))
        b = np.array(_vector(_field(spec, "end", where), 2, where, "end"))
        thickness = _positive(spec.get("thickness", 0.1), where, "thickness")
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
    group = str(data.get("group", "custom"))
    if group not in GROUPS:
        raise WorldFormatError(f"{source}: field 'group' = {group!r} is not one of {GROUPS}")
    obstacles = data.get("obstacles", []) or []
    if not isinstance(obstacles, list):
        raise WorldFormatError(f"{source}: field 'obstacles' must be a list, got {obstacles!r}")
    time_limit = data.get("time_limit")
    world = World(
        name=str(_field(data, "name", source)),
        description=str(_field(data, "description", source)),
        start=_vector(_field(data, "start", source), 3, source, "start"),  # type: ignore[arg-type]
        goal=_vector(_field(data, "goal", source), 2, source, "goal"),  # type: ignore[arg-type]
        obstacles=tuple(
            parse_obstacle(spec, f"{source}: obstacles[{i}]") for i, spec in enumerate(obstacles)
        ),
        group=group,
        time_limit=None if time_limit is None else _positive(time_limit, source, "time_limit"),
        source=source,
    )
    validate_task(world)
    return world


def load_world_file(path: str | Path) -> World:
    """Load a native YAML world, a Gazebo SDF .world/.sdf, or a map_server .yaml map."""
    path = Path(path)
    if not path.is_file():
        raise WorldFormatError(f"{path}: no such world file")
    suffix = path.suffix.lower()
    if suffix in (".world", ".sdf"):
        from d3dwa_bullet.world.sdf import load_sdf_world

        return load_sdf_world(path)
    if suffix not in (".yaml", ".yml"):
        raise WorldFormatError(f"{path}: unknown world file type {suffix!r} (.yaml, .world, .sdf)")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise WorldFormatError(f"{path}: not valid YAML: {err}") from err
    if isinstance(data, Mapping) and "image" in data:
        from d3dwa_bullet.world.map_server import load_map_world

        return load_map_world(path)
    return world_from_dict(data, str(path))


def world_paths() -> dict[str, Path]:
    """Shipped native worlds by name, in file order (TS1..TS4, US1, H1..H3, R1..R3)."""
    order = ["TS1", "TS2", "TS3", "TS4", "US1", "H1", "H2", "H3", "R1", "R2", "R3"]
    found = {p.stem: p for p in sorted(worlds_dir().glob("*.yaml"))}
    names = [n for n in order if n in found] + [n for n in found if n not in order]
    return {n: found[n] for n in names}


def list_worlds() -> list[World]:
    """Every shipped world, loaded."""
    return [load_world_file(p) for p in world_paths().values()]


def load_world(name_or_path: str | Path) -> World:
    """A shipped world by name (case-insensitive) or any world file by path."""
    text = str(name_or_path)
    paths = world_paths()
    by_upper = {n.upper(): p for n, p in paths.items()}
    if text.upper() in by_upper:
        return load_world_file(by_upper[text.upper()])
    if Path(text).suffix:
        return load_world_file(text)
    from d3dwa_bullet.world.generator import generated_world_from_name

    generated = generated_world_from_name(text)
    if generated is not None:
        return generated
    raise UnknownNameError(
        f"unknown world {text!r}: choose one of {', '.join(paths)}, a generated layout such as "
        "R2-style-s17, or a path to a world file"
    )
