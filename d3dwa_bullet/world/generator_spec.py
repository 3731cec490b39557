"""Generator styles: the YAML files of ``worlds/generators/`` that random layouts are drawn from.

Each style (``R1-style.yaml`` ...) holds the goal, the number of obstacles and where they
go, their shapes and sizes, the smallest gap between two obstacles and the clearance kept
from start and goal. Two layouts:

``scatter``
    ``count`` obstacles with centres uniform in ``region`` [xmin, ymin, xmax, ymax].
    Optionally ``line.count`` of them first stand shoulder to shoulder in a line (closed
    gaps) from a point in ``line.first`` along a heading in ``line.heading``.
``rows``
    ``rows.per_row`` obstacles in each row at ``rows.x``; neighbours in a row are
    ``rows.gap`` apart; each later row is offset by ``rows.stagger`` of the mean pitch.

Two obstacles are either at least ``min_gap`` apart or at most ``closed_gap`` apart.
``path_length`` [low, high] m (optional) bounds the shortest inflated route and
``footprint_check`` asks for the planner's footprint to get through; see
:mod:`~d3dwa_bullet.world.generator` for how a layout is drawn and accepted.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import UnknownNameError, WorldFormatError
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.resources import generators_dir
from d3dwa_bullet.world.fields import required, vector

LAYOUTS = ("scatter", "rows")


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
    lo, hi = vector(value, 2, where, key)
    if lo > hi or (positive and lo <= 0):
        raise WorldFormatError(
            f"{where}: field '{key}' must be [low, high] with {'0 < ' if positive else ''}low <= high, got {value!r}"
        )
    return lo, hi


def _scalar(data: Mapping[str, Any], key: str, where: str, default: Any = None) -> float:
    value = data.get(key, default) if default is not None else required(data, key, where)
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
    n = required(data, "count", where)
    if not isinstance(n, int) or not 2 <= n <= count:
        raise WorldFormatError(
            f"{where}: field 'count' must be an integer in [2, {count}], got {n!r}"
        )
    first = vector(required(data, "first", where), 4, where, "first")
    if not (first[0] <= first[2] and first[1] <= first[3]):
        raise WorldFormatError(
            f"{where}: field 'first' must be [xmin, ymin, xmax, ymax], got {first}"
        )
    gap = _range(required(data, "gap", where), where, "gap")
    if gap[1] > closed_gap:
        raise WorldFormatError(
            f"{where}: field 'gap' = {list(gap)} must stay within 'closed_gap' = {closed_gap}"
        )
    heading = _range(required(data, "heading", where), where, "heading", positive=False)
    return LineSpec(count=n, first=first, heading=heading, gap=gap)  # type: ignore[arg-type]


def parse_generator(data: Any, source: str) -> GeneratorSpec:
    """Validate a generator style mapping (the YAML file's content)."""
    where = source
    if not isinstance(data, Mapping):
        raise WorldFormatError(f"{where}: top level must be a mapping, got {type(data).__name__}")
    layout = str(required(data, "layout", where))
    if layout not in LAYOUTS:
        raise WorldFormatError(f"{where}: field 'layout' = {layout!r} is not one of {LAYOUTS}")
    shapes = required(data, "shapes", where)
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
        style=str(required(data, "style", where)),
        description=str(required(data, "description", where)),
        goal=vector(required(data, "goal", where), 2, where, "goal"),
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
        count = required(data, "count", where)
        if not isinstance(count, int) or count < 1:
            raise WorldFormatError(f"{where}: field 'count' must be an integer >= 1, got {count!r}")
        region = vector(required(data, "region", where), 4, where, "region")
        if not (region[0] < region[2] and region[1] < region[3]):
            raise WorldFormatError(
                f"{where}: field 'region' must be [xmin, ymin, xmax, ymax], got {region}"
            )
        spec.update(count=count, region=region)
        if "line" in data:
            spec["line"] = _parse_line(data["line"], f"{where}: line", count, spec["closed_gap"])
    else:
        rows = required(data, "rows", where)
        rwhere = f"{where}: rows"
        if not isinstance(rows, Mapping):
            raise WorldFormatError(f"{where}: field 'rows' must be a mapping, got {rows!r}")
        xs = required(rows, "x", rwhere)
        if not isinstance(xs, list) or not xs:
            raise WorldFormatError(
                f"{rwhere}: field 'x' must be a non-empty list of numbers, got {xs!r}"
            )
        row_x = vector(xs, len(xs), rwhere, "x")
        per_row = required(rows, "per_row", rwhere)
        if not isinstance(per_row, int) or per_row < 1:
            raise WorldFormatError(
                f"{rwhere}: field 'per_row' must be an integer >= 1, got {per_row!r}"
            )
        spec["rows"] = RowsSpec(
            x=row_x,
            per_row=per_row,
            gap=_range(required(rows, "gap", rwhere), rwhere, "gap"),
            center_y=vector([rows.get("center_y", 0.0)], 1, rwhere, "center_y")[0],
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
    return parse_generator(load_yaml(path, WorldFormatError, "generator YAML"), str(path))
