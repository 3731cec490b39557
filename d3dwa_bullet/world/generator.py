"""Random layouts in the style of the real-style worlds R1-R3.

Each style is a YAML file in ``worlds/generators/`` (``R1-style.yaml`` ...) holding the
goal, the number of obstacles and where they go, their shapes and sizes, the smallest
gap between two obstacles and the clearance kept from start and goal. Two layouts:

``scatter``
    ``count`` obstacles with centres uniform in ``region`` [xmin, ymin, xmax, ymax].
    Optionally ``line.count`` of them first stand shoulder to shoulder in a line (closed
    gaps) from a point in ``line.first`` along a heading in ``line.heading``.
``rows``
    ``rows.per_row`` obstacles in each row at ``rows.x``; neighbours in a row are
    ``rows.gap`` apart; each later row is offset by ``rows.stagger`` of the mean pitch.

Two obstacles are either at least ``min_gap`` apart or at most ``closed_gap`` apart (a
gap too narrow for the robot, so clusters form without in-between gaps that look
passable but are not). A layout is rejected and redrawn when an obstacle comes within
``clear_endpoints`` of the start (0, 0) or the goal, when no route exists for base_link
with obstacles inflated by the planner's r + m (:func:`world_grid.shortest_path`), when
that route's length is outside ``path_length`` [low, high] m (optional; keeps a style
near its world's route length), or, with ``footprint_check``, when the planner's
three-circle footprint cannot get through.

:func:`generate_world` draws only from ``numpy.random.default_rng(seed)``: the same style
and seed give the same world, run after run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from d3dwa_bullet.errors import ConfigError, D3DWAError, UnknownNameError, WorldFormatError
from d3dwa_bullet.resources import generators_dir
from d3dwa_bullet.world.grid import footprint_reachable, gap_between, shortest_path
from d3dwa_bullet.world.model import (
    Box,
    Cylinder,
    Obstacle,
    World,
    _field,
    _vector,
    obstacle_distance,
    validate_task,
)

START = (0.0, 0.0, 0.0)
"""Every generated world starts at the origin facing +x (SPEC section 8)."""
LAYOUTS = ("scatter", "rows")
PLACEMENT_ATTEMPTS = 400
"""Draws per obstacle before the layout is abandoned and restarted."""
LAYOUT_ATTEMPTS = 200
"""Layouts drawn before giving up on a seed."""


@dataclass(frozen=True)
class RowsSpec:
    """Staggered rows across the way to the goal (layout ``rows``)."""

    x: tuple[float, ...]
    """Row positions along x, m."""
    per_row: int
    """Obstacles in each row."""
    gap: tuple[float, float]
    """Range of the free space between neighbours in a row, m."""
    center_y: float = 0.0
    """The first row is centred on this y, m ..."""
    shift: tuple[float, float] = (0.0, 0.0)
    """... plus a uniform random shift in this range, m."""
    stagger: float = 0.5
    """Offset of each row from the previous one, as a fraction of the mean pitch."""
    x_jitter: float = 0.0
    """Each obstacle's x is drawn within +- this of its row, m."""


@dataclass(frozen=True)
class LineSpec:
    """Obstacles standing shoulder to shoulder in a line (part of a ``scatter`` layout)."""

    count: int
    """How many of the layout's obstacles form the line."""
    first: tuple[float, float, float, float]
    """Region [xmin, ymin, xmax, ymax] of the first obstacle's centre, m."""
    heading: tuple[float, float]
    """Range of the line's direction, rad."""
    gap: tuple[float, float]
    """Range of the free space between neighbours, m; at most ``closed_gap``."""


@dataclass(frozen=True)
class GeneratorSpec:
    """One generator style, as read from ``worlds/generators/<style>.yaml``."""

    style: str
    description: str
    goal: tuple[float, float]
    layout: str
    shapes: tuple[tuple[str, float], ...]
    """(shape, probability) pairs, probabilities summing to 1."""
    box_side: tuple[float, float]
    box_yaw: tuple[float, float]
    cylinder_radius: tuple[float, float]
    min_gap: float
    closed_gap: float
    clear_endpoints: float
    footprint_check: bool
    path_length: tuple[float, float] = (0.0, math.inf)
    """Accepted range of the shortest inflated route, m."""
    count: int = 0
    region: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    rows: RowsSpec | None = None
    line: LineSpec | None = None
    source: str = "<memory>"


def list_generator_styles() -> list[str]:
    """Names of the shipped generator styles, sorted (e.g. R1-style, R2-style, R3-style)."""
    return sorted(p.stem for p in generators_dir().glob("*.yaml"))


def _range(value: Any, where: str, key: str, positive: bool = True) -> tuple[float, float]:
    lo, hi = _vector(value, 2, where, key)
    if lo > hi or (positive and lo <= 0):
        raise WorldFormatError(
            f"{where}: field '{key}' must be [low, high] with {'0 < ' if positive else ''}low <= high, got {value!r}"
        )
    return lo, hi


def _scalar(data: Mapping[str, Any], key: str, where: str, default: Any = None) -> float:
    value = data.get(key, default) if default is not None else _field(data, key, where)
    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise WorldFormatError(f"{where}: field '{key}' must be a number, got {value!r}") from err
    if not (math.isfinite(v) and v >= 0):
        raise WorldFormatError(f"{where}: field '{key}' must be >= 0, got {value!r}")
    return v


def _parse_line(data: Any, where: str, count: int, closed_gap: float) -> LineSpec:
    if not isinstance(data, Mapping):
        raise WorldFormatError(f"{where}: must be a mapping, got {data!r}")
    n = _field(data, "count", where)
    if not isinstance(n, int) or not 2 <= n <= count:
        raise WorldFormatError(
            f"{where}: field 'count' must be an integer in [2, {count}], got {n!r}"
        )
    first = _vector(_field(data, "first", where), 4, where, "first")
    if not (first[0] <= first[2] and first[1] <= first[3]):
        raise WorldFormatError(
            f"{where}: field 'first' must be [xmin, ymin, xmax, ymax], got {first}"
        )
    gap = _range(_field(data, "gap", where), where, "gap")
    if gap[1] > closed_gap:
        raise WorldFormatError(
            f"{where}: field 'gap' = {list(gap)} must stay within 'closed_gap' = {closed_gap}"
        )
    heading = _range(_field(data, "heading", where), where, "heading", positive=False)
    return LineSpec(count=n, first=first, heading=heading, gap=gap)  # type: ignore[arg-type]


def parse_generator(data: Any, source: str) -> GeneratorSpec:
    """Validate a generator style mapping (the YAML file's content)."""
    where = source
    if not isinstance(data, Mapping):
        raise WorldFormatError(f"{where}: top level must be a mapping, got {type(data).__name__}")
    layout = str(_field(data, "layout", where))
    if layout not in LAYOUTS:
        raise WorldFormatError(f"{where}: field 'layout' = {layout!r} is not one of {LAYOUTS}")
    shapes = _field(data, "shapes", where)
    if not isinstance(shapes, Mapping) or not shapes:
        raise WorldFormatError(f"{where}: field 'shapes' must map box/cylinder to probabilities")
    probs = {}
    for name in shapes:
        if name not in ("box", "cylinder"):
            raise WorldFormatError(
                f"{where}: field 'shapes' has unknown shape {name!r} (box, cylinder)"
            )
        probs[name] = _scalar(shapes, name, where)
    total = sum(probs.values())
    if not total > 0:
        raise WorldFormatError(f"{where}: field 'shapes' probabilities must not all be 0")
    spec: dict[str, Any] = dict(
        style=str(_field(data, "style", where)),
        description=str(_field(data, "description", where)),
        goal=_vector(_field(data, "goal", where), 2, where, "goal"),
        layout=layout,
        shapes=tuple((k, v / total) for k, v in sorted(probs.items())),
        box_side=_range(data.get("box_side", [0.3, 0.3]), where, "box_side"),
        box_yaw=_range(data.get("box_yaw", [0.0, 0.0]), where, "box_yaw", positive=False),
        cylinder_radius=_range(data.get("cylinder_radius", [0.15, 0.15]), where, "cylinder_radius"),
        min_gap=_scalar(data, "min_gap", where),
        closed_gap=_scalar(data, "closed_gap", where, 0.0),
        clear_endpoints=_scalar(data, "clear_endpoints", where),
        footprint_check=bool(data.get("footprint_check", False)),
        path_length=_range(
            data.get("path_length", [0.0, math.inf]), where, "path_length", positive=False
        ),
        source=source,
    )
    if spec["closed_gap"] >= spec["min_gap"]:
        raise WorldFormatError(
            f"{where}: field 'closed_gap' = {spec['closed_gap']} must be < 'min_gap' = {spec['min_gap']}"
        )
    if layout == "scatter":
        count = _field(data, "count", where)
        if not isinstance(count, int) or count < 1:
            raise WorldFormatError(f"{where}: field 'count' must be an integer >= 1, got {count!r}")
        region = _vector(_field(data, "region", where), 4, where, "region")
        if not (region[0] < region[2] and region[1] < region[3]):
            raise WorldFormatError(
                f"{where}: field 'region' must be [xmin, ymin, xmax, ymax], got {region}"
            )
        spec.update(count=count, region=region)
        if "line" in data:
            spec["line"] = _parse_line(data["line"], f"{where}: line", count, spec["closed_gap"])
    else:
        rows = _field(data, "rows", where)
        rwhere = f"{where}: rows"
        if not isinstance(rows, Mapping):
            raise WorldFormatError(f"{where}: field 'rows' must be a mapping, got {rows!r}")
        xs = _field(rows, "x", rwhere)
        if not isinstance(xs, list) or not xs:
            raise WorldFormatError(
                f"{rwhere}: field 'x' must be a non-empty list of numbers, got {xs!r}"
            )
        row_x = _vector(xs, len(xs), rwhere, "x")
        per_row = _field(rows, "per_row", rwhere)
        if not isinstance(per_row, int) or per_row < 1:
            raise WorldFormatError(
                f"{rwhere}: field 'per_row' must be an integer >= 1, got {per_row!r}"
            )
        spec["rows"] = RowsSpec(
            x=row_x,
            per_row=per_row,
            gap=_range(_field(rows, "gap", rwhere), rwhere, "gap"),
            center_y=_vector([rows.get("center_y", 0.0)], 1, rwhere, "center_y")[0],
            shift=_range(rows.get("shift", [0.0, 0.0]), rwhere, "shift", positive=False),
            stagger=_scalar(rows, "stagger", rwhere, 0.5),
            x_jitter=_scalar(rows, "x_jitter", rwhere, 0.0),
        )
        spec["count"] = per_row * len(row_x)
    return GeneratorSpec(**spec)


def load_generator(style: str | Path) -> GeneratorSpec:
    """A shipped style by name (case-insensitive) or a generator YAML by path."""
    text = str(style)
    by_upper = {s.upper(): generators_dir() / f"{s}.yaml" for s in list_generator_styles()}
    path = by_upper.get(text.upper())
    if path is None:
        if not text.endswith((".yaml", ".yml")):
            raise UnknownNameError(
                f"unknown generator style {text!r}: choose one of {', '.join(list_generator_styles())} "
                "or give a path to a generator YAML"
            )
        path = Path(text)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise WorldFormatError(f"{path}: cannot read generator YAML: {err}") from err
    return parse_generator(data, str(path))


def _draw_shape(
    spec: GeneratorSpec, rng: np.random.Generator, center: tuple[float, float]
) -> Obstacle:
    cumulative = np.cumsum([p for _, p in spec.shapes])
    index = min(int(np.searchsorted(cumulative, rng.random(), side="right")), len(cumulative) - 1)
    kind = spec.shapes[index][0]
    if kind == "cylinder":
        return Cylinder(center=center, radius=float(rng.uniform(*spec.cylinder_radius)))
    size = rng.uniform(*spec.box_side, size=2)
    return Box(
        center=center, size=(float(size[0]), float(size[1])), yaw=float(rng.uniform(*spec.box_yaw))
    )


def _moved(ob: Obstacle, center: tuple[float, float]) -> Obstacle:
    if isinstance(ob, Cylinder):
        return Cylinder(center=center, radius=ob.radius, height=ob.height)
    return Box(center=center, size=ob.size, yaw=ob.yaw, height=ob.height)


def _reach(ob: Obstacle) -> float:
    """Radius of the obstacle's bounding circle about its centre, m."""
    return ob.radius if isinstance(ob, Cylinder) else 0.5 * math.hypot(*ob.size)


def _fits(spec: GeneratorSpec, ob: Obstacle, placed: list[Obstacle]) -> bool:
    """Clear of start and goal, and no in-between gap to any placed obstacle."""
    ends = np.array([START[:2], spec.goal])
    if (obstacle_distance(ob, ends) < spec.clear_endpoints).any():
        return False
    for other in placed:
        # bounding circles far enough apart settle it without measuring the outlines
        if math.dist(ob.center, other.center) - _reach(ob) - _reach(other) >= spec.min_gap:
            continue
        g = gap_between(ob, other)
        if not (g >= spec.min_gap or 0.0 < g <= spec.closed_gap):
            return False
    return True


def _support(ob: Obstacle, theta: float) -> float:
    """Half extent of an obstacle along direction theta, m."""
    if isinstance(ob, Cylinder):
        return ob.radius
    return 0.5 * (
        abs(ob.size[0] * math.cos(ob.yaw - theta)) + abs(ob.size[1] * math.sin(ob.yaw - theta))
    )


def _line(spec: GeneratorSpec, rng: np.random.Generator) -> list[Obstacle] | None:
    line = spec.line
    assert line is not None
    theta = float(rng.uniform(*line.heading))
    u = np.array([math.cos(theta), math.sin(theta)])
    at = np.array(
        [rng.uniform(line.first[0], line.first[2]), rng.uniform(line.first[1], line.first[3])]
    )
    placed: list[Obstacle] = []
    for k in range(line.count):
        ob = _draw_shape(spec, rng, (0.0, 0.0))
        if k:
            at = at + u * (
                _support(placed[-1], theta) + float(rng.uniform(*line.gap)) + _support(ob, theta)
            )
        ob = _moved(ob, (float(at[0]), float(at[1])))
        if not _fits(spec, ob, placed):
            return None
        placed.append(ob)
    return placed


def _scatter(spec: GeneratorSpec, rng: np.random.Generator) -> list[Obstacle] | None:
    xmin, ymin, xmax, ymax = spec.region
    placed: list[Obstacle] = []
    if spec.line is not None:
        placed = _line(spec, rng) or []
        if not placed:
            return None
    for _ in range(spec.count - len(placed)):
        for _ in range(PLACEMENT_ATTEMPTS):
            center = (float(rng.uniform(xmin, xmax)), float(rng.uniform(ymin, ymax)))
            ob = _draw_shape(spec, rng, center)
            if _fits(spec, ob, placed):
                placed.append(ob)
                break
        else:
            return None
    return placed


def _half_width_y(ob: Obstacle) -> float:
    if isinstance(ob, Cylinder):
        return ob.radius
    return 0.5 * (abs(math.sin(ob.yaw)) * ob.size[0] + abs(math.cos(ob.yaw)) * ob.size[1])


def _rows(spec: GeneratorSpec, rng: np.random.Generator) -> list[Obstacle] | None:
    rows = spec.rows
    assert rows is not None
    mean_size = 0.5 * (
        sum(p * sum(spec.box_side) for s, p in spec.shapes if s == "box")
        + sum(p * 2 * sum(spec.cylinder_radius) for s, p in spec.shapes if s == "cylinder")
    )
    pitch = mean_size + 0.5 * sum(rows.gap)
    base = rows.center_y + float(rng.uniform(*rows.shift))
    placed: list[Obstacle] = []
    for r, x in enumerate(rows.x):
        shapes = [_draw_shape(spec, rng, (0.0, 0.0)) for _ in range(rows.per_row)]
        gaps = rng.uniform(*rows.gap, size=rows.per_row - 1)
        halves = np.array([_half_width_y(ob) for ob in shapes])
        # centres along y, neighbours exactly gap apart, the row centred on its offset
        ys = np.concatenate(([0.0], np.cumsum(halves[:-1] + gaps + halves[1:])))
        ys += base + r * rows.stagger * pitch - 0.5 * (ys[0] + ys[-1])
        xs = x + rng.uniform(-rows.x_jitter, rows.x_jitter, size=rows.per_row)
        for ob, cx, cy in zip(shapes, xs, ys, strict=True):
            moved = _moved(ob, (float(cx), float(cy)))
            if not _fits(spec, moved, placed):
                return None
            placed.append(moved)
    return placed


def generate_world(style: str, seed: int) -> World:
    """A passable R1/R2/R3-style world, the same for the same (style, seed).

    Named ``{style}-s{seed}`` (e.g. ``R2-style-s17``), group "custom". Raises
    UnknownNameError for an unknown style, WorldFormatError for a malformed style file,
    ConfigError if no acceptable layout is found in LAYOUT_ATTEMPTS draws.
    """
    spec = load_generator(style)
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"generate_world: seed must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng(int(seed))
    draw = _scatter if spec.layout == "scatter" else _rows
    for _ in range(LAYOUT_ATTEMPTS):
        obstacles = draw(spec, rng)
        if obstacles is None:
            continue
        world = World(
            name=f"{spec.style}-s{seed}",
            description=f"{spec.description} (generated, seed {seed})",
            start=START,
            goal=spec.goal,  # type: ignore[arg-type]
            obstacles=tuple(obstacles),
            group="custom",
            source=f"generator {spec.style} seed {seed}",
        )
        try:
            validate_task(world)
            length = shortest_path(world).length
        except D3DWAError:
            continue
        if not spec.path_length[0] <= length <= spec.path_length[1]:
            continue
        if spec.footprint_check and not footprint_reachable(world):
            continue
        return world
    raise ConfigError(
        f"{spec.source}: no passable layout in {LAYOUT_ATTEMPTS} draws for seed {seed}; "
        "loosen 'min_gap', 'region' or the obstacle sizes"
    )


def generated_world_from_name(name: str) -> World | None:
    """'R2-style-s17' -> generate_world('R2-style', 17); None if name is not of that form."""
    style, sep, seed = name.rpartition("-s")
    if not sep or not seed.isdigit() or style not in list_generator_styles():
        return None
    return generate_world(style, int(seed))
