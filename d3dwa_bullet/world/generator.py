"""Random layouts in the style of the real-style worlds R1-R3, drawn from a generator style.

A style (:mod:`~d3dwa_bullet.world.generator_spec`) says how many obstacles of which shapes
go where. Two obstacles are either at least ``min_gap`` apart or at most ``closed_gap``
apart (a gap too narrow for the robot, so clusters form without in-between gaps that look
passable but are not). A layout is rejected and redrawn when an obstacle comes within
``clear_endpoints`` of the start (0, 0) or the goal, when no route exists for base_link
with obstacles inflated by the planner's r + m (:func:`~d3dwa_bullet.world.routes.shortest_path`),
when that route's length is outside ``path_length`` (keeps a style near its world's route
length), or, with ``footprint_check``, when the planner's three-circle footprint cannot
get through.

:func:`generate_world` draws only from ``numpy.random.default_rng(seed)``: the same style
and seed give the same world, run after run. Training draws layout seeds from
[0, ``UNSEEN_LAYOUT_SEED_BASE``); the noise sweep's unseen layouts use seeds from
``UNSEEN_LAYOUT_SEED_BASE`` up, so they are never trained on.
"""

from __future__ import annotations

import math

import numpy as np

from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.world.gaps import gap_between
from d3dwa_bullet.world.generator_spec import GeneratorSpec, list_generator_styles, load_generator
from d3dwa_bullet.world.model import (
    Box,
    Cylinder,
    Obstacle,
    World,
    obstacle_distance,
    validate_task,
)
from d3dwa_bullet.world.reachability import footprint_reachable
from d3dwa_bullet.world.routes import shortest_path

START = (0.0, 0.0, 0.0)
"""Every generated world starts at the origin facing +x (docs/design/worlds.md#worlds)."""
PLACEMENT_ATTEMPTS = 400
"""Draws per obstacle before the layout is abandoned and restarted."""
LAYOUT_ATTEMPTS = 200
"""Layouts drawn before giving up on a seed."""
UNSEEN_LAYOUT_SEED_BASE = 2**31
"""First layout seed never used in training: training draws generator seeds from
[0, 2^31) (``integers(UNSEEN_LAYOUT_SEED_BASE)``), the noise sweep's unseen layouts use
2^31, 2^31 + 1, ... (or from its ``--layout-seed`` up)."""
MAX_LAYOUT_SEED = 2**63 - 1
"""Largest layout seed a sweep names (numpy's generator takes any int >= 0; names stay one int64)."""


def check_unseen_seeds(first: int, count: int, option: str = "--layout-seed") -> int:
    """``first`` if ``first .. first + count - 1`` are all seeds training never draws, in
    [UNSEEN_LAYOUT_SEED_BASE, MAX_LAYOUT_SEED]; else ConfigError naming the option, the value
    and the range training uses."""
    if isinstance(first, bool) or not isinstance(first, int | np.integer):
        raise ConfigError(f"{option}: a layout seed is an integer, got {first!r}")
    if first < UNSEEN_LAYOUT_SEED_BASE:
        raise ConfigError(
            f"{option} {first}: training draws generated layouts' seeds from [0, 2^31 = "
            f"{UNSEEN_LAYOUT_SEED_BASE}); unseen layouts start at {UNSEEN_LAYOUT_SEED_BASE} or more"
        )
    if first + max(count, 1) - 1 > MAX_LAYOUT_SEED:
        raise ConfigError(
            f"{option} {first}: with {count} layouts per style the last seed passes 2^63 - 1 "
            f"({MAX_LAYOUT_SEED})"
        )
    return int(first)


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


def generated_style(name: str) -> str | None:
    """'R2-style-s17' -> 'R2-style': the shipped style of a generated layout's name, without
    generating it; None if name is not of that form."""
    style, sep, seed = name.rpartition("-s")
    if not sep or not seed.isdigit() or style not in list_generator_styles():
        return None
    return style


def generated_world_from_name(name: str) -> World | None:
    """'R2-style-s17' -> generate_world('R2-style', 17); None if name is not of that form."""
    style = generated_style(name)
    if style is None:
        return None
    return generate_world(style, int(name.rpartition("-s")[2]))
