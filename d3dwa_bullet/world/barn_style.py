"""Fresh BARN-style worlds: BARN's published recipe, drawn from a seed (docs/design/barn-style.md).

A BARN-style world is made as BARN made its 300 (shared reference: barn-facts.md):

- a 30x30 cellular automaton: rows 0 and 29 filled, every other cell filled with probability
  ``fill``, then ``smoothing`` passes, each filling a cell with 5 or more of its 8 neighbours
  filled and clearing one with 1 or fewer (all at once; a neighbour beyond row 0 or 29 counts
  as filled, one beyond the first or last column as free);
- kept only when a 5x5-cell robot can cross from column 0 to column 29
  (:func:`~d3dwa_bullet.world.barn_path.crossing_region`), with a start row and an end row
  drawn among that region's cells of the two columns and BARN's reference path between them
  (:func:`~d3dwa_bullet.world.barn_path.barn_search`); a grid that fails is drawn again;
- the grid's cylinders, the start box and BARN's task (start, goal, 100 s) exactly as for
  BARN's own worlds (:func:`~d3dwa_bullet.world.barn.barn_cylinders`), and the reference path
  length as BARN's scorer takes it (:func:`~d3dwa_bullet.world.barn.path_length`).

BARN drew 25 kept worlds for each of its 12 settings (fill 0.15, 0.20, 0.25, 0.30 x 2, 3, 4
passes). Seed ``s`` uses setting ``s mod 12`` (:data:`SETTINGS`), so any 12 consecutive seeds
hold each setting once, and draws only from ``numpy.random.default_rng(s)``: the same seed
gives the same world. Training draws seeds from [0, 2^31) (as for R-style layouts,
:data:`~d3dwa_bullet.world.generator.UNSEEN_LAYOUT_SEED_BASE`); evaluation takes seeds from
2^31 up, :func:`check_eval_seed` refuses the others. A world is named ``BARN-style-s<seed>``
and its group is ``barn-style``: never one of BARN's.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.barn import (
    GOAL,
    GRID_SIZE,
    START,
    TIME_LIMIT,
    barn_cylinders,
    path_length,
)
from d3dwa_bullet.world.barn_path import barn_search, c_space, crossing_region
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from d3dwa_bullet.world.model import World, validate_task

STYLE = "BARN-style"
"""The family's name: a training config's generator style, and its worlds' name prefix."""
GROUP = "barn-style"
"""The group of every BARN-style world (tables show its rows under it)."""
FILLS = (0.15, 0.20, 0.25, 0.30)
"""BARN's initial fill probabilities."""
SMOOTHINGS = (2, 3, 4)
"""BARN's numbers of smoothing passes."""
SETTINGS = tuple((fill, passes) for fill in FILLS for passes in SMOOTHINGS)
"""The 12 (fill, passes) settings; seed s uses SETTINGS[s % 12]."""
FILL_AT = 5
"""Smoothing fills a cell with at least this many filled neighbours..."""
CLEAR_AT = 1
"""...and clears one with at most this many."""
TRAINING_SEEDS = UNSEEN_LAYOUT_SEED_BASE
"""Training draws BARN-style seeds from [0, TRAINING_SEEDS = 2^31); evaluation seeds are >= it
(the bound of R-style layouts)."""
MAX_SEED = 2**63 - 1
"""Largest seed (numpy's generator takes any int >= 0; names stay one int64)."""
DRAWS = 200_000
"""Grids drawn for one seed before giving up. Fill 0.30 with 2 passes keeps about 1 grid in 1,500,
so a seed fails with probability about exp(-130): never in practice."""
_NAME = re.compile(r"barn-style-s(\d+)", re.IGNORECASE)
_NEIGHBOURS = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]])


@dataclass(frozen=True)
class BarnStyleDraw:
    """One kept draw: the grid, its reference path and how it was made."""

    seed: int
    fill: float
    passes: int
    grid: np.ndarray
    """(30, 30) bool, True = filled."""
    path: np.ndarray
    """(K, 2) int64 cells (row, column), the start cell twice first, as BARN's path files."""
    draws: int
    """Grids drawn for this seed, this one included."""


def smooth(grid: np.ndarray) -> np.ndarray:
    """One smoothing pass of a (30, 30) bool grid (module docstring): (30, 30) bool."""
    grid = np.asarray(grid, dtype=bool)
    padded = np.pad(grid.astype(np.int64), ((0, 0), (1, 1)), constant_values=0)
    padded = np.pad(padded, ((1, 1), (0, 0)), constant_values=1)  # rows beyond are walls
    counts = ndimage.convolve(padded, _NEIGHBOURS, mode="constant", cval=0)[1:-1, 1:-1]
    out = grid.copy()
    out[counts >= FILL_AT] = True
    out[counts <= CLEAR_AT] = False
    return out


def automaton(rng: np.random.Generator, fill: float, passes: int) -> np.ndarray:
    """A (30, 30) bool grid: walls on rows 0 and 29, the rest filled with probability fill
    (one ``rng.random`` draw per cell, row by row), then ``passes`` smoothing passes."""
    grid = np.ones((GRID_SIZE, GRID_SIZE), dtype=bool)
    grid[1:-1] = rng.random((GRID_SIZE - 2, GRID_SIZE)) < fill
    for _ in range(passes):
        grid = smooth(grid)
    return grid


def check_seed(seed: object, option: str = "seed") -> int:
    """``seed`` as an int if it is an integer in [0, MAX_SEED], else ConfigError naming it."""
    if (
        isinstance(seed, bool)
        or not isinstance(seed, int | np.integer)
        or not 0 <= seed <= MAX_SEED
    ):
        raise ConfigError(
            f"{option}: a BARN-style seed is an integer in [0, {MAX_SEED}], got {seed!r}"
        )
    return int(seed)


def check_eval_seed(seed: object, count: int = 1, option: str = "--seed") -> int:
    """``seed`` if ``seed .. seed + count - 1`` are all evaluation seeds (>= TRAINING_SEEDS);
    ConfigError naming the value if any is one training draws from."""
    seed = check_seed(seed, option)
    if seed < TRAINING_SEEDS:
        raise ConfigError(
            f"{option} {seed}: BARN-style seeds below {TRAINING_SEEDS} (2^31) are the ones training "
            f"draws from; evaluate on seeds from {TRAINING_SEEDS} up"
        )
    check_seed(seed + count - 1, option)
    return seed


def barn_style_draw(seed: int) -> BarnStyleDraw:
    """The kept draw of ``seed`` (module docstring). ConfigError if DRAWS grids all fail."""
    seed = check_seed(seed)
    fill, passes = SETTINGS[seed % len(SETTINGS)]
    rng = np.random.default_rng(seed)
    for draw in range(1, DRAWS + 1):
        grid = automaton(rng, fill, passes)
        blocked = c_space(grid)
        region = crossing_region(blocked)
        if region is None:
            continue
        lefts, rights = np.flatnonzero(region[:, 0]), np.flatnonzero(region[:, -1])
        start = (int(lefts[rng.integers(len(lefts))]), 0)
        end = (int(rights[rng.integers(len(rights))]), GRID_SIZE - 1)
        path = barn_search(blocked, start, end)
        if path is not None:
            return BarnStyleDraw(seed, fill, passes, grid, path, draw)
    raise ConfigError(f"BARN-style seed {seed}: no crossable grid in {DRAWS} draws")


def barn_style_name(seed: int) -> str:
    """``BARN-style-s<seed>``."""
    return f"{STYLE}-s{check_seed(seed)}"


def barn_style_world(seed: int) -> World:
    """The BARN-style world of ``seed``: BARN's task on a fresh grid, group ``barn-style``,
    with its reference path's length (BARN's scorer's L)."""
    drawn = barn_style_draw(seed)
    world = World(
        name=barn_style_name(drawn.seed),
        description=(
            f"BARN-style world, seed {drawn.seed} (fill {drawn.fill:.2f}, {drawn.passes} smoothing "
            "passes): BARN's recipe, not one of BARN's worlds"
        ),
        start=START,
        goal=GOAL,
        obstacles=barn_cylinders(drawn.grid),
        group=GROUP,
        time_limit=TIME_LIMIT,
        source=f"barn-style:{drawn.seed}",
        reference_length=path_length(drawn.path),
    )
    validate_task(world)
    return world


def barn_style_seed(name: str) -> int | None:
    """The seed a name such as ``BARN-style-s2147483648`` (any case) names, or None if the name
    is not of that form; ConfigError if the seed is out of range."""
    match = _NAME.fullmatch(name.strip())
    return None if match is None else check_seed(int(match.group(1)), f"world {name!r}")


def barn_style_group(name: str) -> str | None:
    """``barn-style`` for a BARN-style world's name, else None (as BARN's tercile_group)."""
    return None if _NAME.fullmatch(name.strip()) is None else GROUP


def is_eval_world(world: World) -> bool:
    """True for a BARN-style world of an evaluation seed (>= TRAINING_SEEDS): never trained on."""
    seed = barn_style_seed(world.name) if world.group == GROUP else None
    return seed is not None and seed >= TRAINING_SEEDS


def barn_style_world_from_name(name: str) -> World | None:
    """The BARN-style world a name names, or None (see :func:`barn_style_seed`)."""
    seed = barn_style_seed(name)
    return None if seed is None else barn_style_world(seed)


def barn_style_names(
    count: object, seed: object, option: str = "--count", seed_option: str = "--seed"
) -> list[str]:
    """Names of ``count`` BARN-style evaluation worlds from ``seed`` on: ConfigError naming the
    value unless count is a positive integer and every seed one training never draws."""
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise ConfigError(
            f"{option} must be a positive integer (a number of worlds), got {count!r}"
        )
    first = check_eval_seed(seed, int(count), seed_option)
    return [barn_style_name(first + i) for i in range(int(count))]
