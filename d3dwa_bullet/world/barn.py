"""BARN's 300 worlds (the-barn-challenge, MIT licence), rebuilt from their occupancy grids.

Each BARN world is a 30x30 occupancy grid whose filled cells are cylinders (radius 0.075 m)
on a 0.15 m lattice: cell (row r, column c) stands at x = -4.425 + 0.15 r, y = 5.175 + 0.15 c
(m). BARN's world writer leaves out a filled cell whose 8 neighbours are all filled (cells
outside the grid count as free), so only the :func:`written_cells` of a grid are cylinders.
A U-shaped start box of 96 more cylinders, :func:`wall_cells`, closes the lattice below the
grid (columns -34..-1): rows 0 and 29 continue as side walls and column -34 is the floor.
The task is BARN's: start (-2.25, 3) facing +y, goal (-2.25, 13) beyond the grid's open
end, 100 s.

The grids and reference paths ship as package data (``d3dwa_bullet/data/barn/``, one text
file per world, made once by ``tools/barn_convert.py``); a file is read only if its SHA-256
matches the folder's ``SHA256SUMS``. ``docs/worlds.md`` (BARN) gives the source, licence,
splits and why the goal tolerance stays the testbed's own.
"""

from __future__ import annotations

import hashlib
import math
import re
from functools import cache
from pathlib import Path

import numpy as np
from scipy import ndimage

from d3dwa_bullet.errors import ConfigError, InstallError, UnknownNameError, WorldFormatError
from d3dwa_bullet.resources import barn_dir
from d3dwa_bullet.world.model import Cylinder, World, validate_task

BARN_WORLDS = 300
"""Worlds in the suite: BARN-0 .. BARN-299."""
GRID_SIZE = 30
"""Rows and columns of a BARN occupancy grid."""
CELL_MM = 150
"""Lattice spacing, mm (integers keep the centres exactly those of BARN's files)."""
ORIGIN_MM = (-4425, 5175)
"""Centre of grid cell (0, 0), mm."""
RADIUS = 0.075
"""Radius of every BARN cylinder, m."""
HEIGHT = 0.5
"""Top of every BARN cylinder, m (a 1 m cylinder centred on the floor, as the files place it)."""
CORRIDOR_COLUMNS = 34
"""Columns of the start box below the grid (-34..-1)."""
START = (-2.25, 3.0, math.pi / 2)
"""BARN's start pose (x m, y m, yaw rad), as run.py since 2024-02-04."""
GOAL = (-2.25, 13.0)
"""BARN's goal (x, y), m: 10 m ahead of the start."""
TIME_LIMIT = 100.0
"""BARN's time limit, s."""
PATH_SCALE = 0.15
PATH_OFFSET = (-4.575, 5.075)
"""run.py's map from a path cell (px, py) to (x, y) m: x = 0.15 px - 4.575, y = 0.15 py + 5.075
(about a cell off the cylinder lattice; kept so the path lengths are BARN's own)."""
CHALLENGE_STEP = 6
"""The challenge split is every sixth world: 0, 6, ..., 294."""
SPLITS = ("challenge", "train", "all")
"""BARN's splits: ``challenge`` (50 worlds, never trained or validated on), ``train`` (the other
250) and ``all``."""
SPLIT_GROUPS = {"challenge": "barn-challenge", "train": "barn-train"}
"""A BARN world's group, by split: what tables show per split. Training refuses
``barn-challenge`` (:data:`~d3dwa_bullet.world.native.EVAL_ONLY_GROUPS`)."""
MANIFEST = "SHA256SUMS"
_NAME = re.compile(r"barn-(\d+)", re.IGNORECASE)
_NEIGHBOURS = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]])


def written_cells(grid: np.ndarray) -> np.ndarray:
    """The filled cells BARN's writer makes cylinders of: (30, 30) bool.

    grid: (30, 30) bool, True = filled. A filled cell is left out when all 8 neighbours are
    filled; a neighbour outside the grid counts as free, so the border is always written.
    """
    grid = np.asarray(grid, dtype=bool)
    filled = ndimage.convolve(grid.astype(np.int64), _NEIGHBOURS, mode="constant", cval=0)
    return grid & (filled < 8)


def recover_grid(written: np.ndarray) -> np.ndarray:
    """The occupancy grid (30, 30) bool whose :func:`written_cells` are ``written``.

    A cell the writer left out has all 8 neighbours filled, so every 8-connected patch of
    unwritten cells is either all left out or all free, and a left-out patch cannot touch the
    border. A sealed patch is taken as filled when the grid, so filled, still writes back to
    ``written`` (filling a free pocket would hide the cells around it), patch by patch in
    label order. A free pocket that could also be filled reads as filled: no robot can reach
    one, and the cylinders are the same either way.
    """
    written = np.asarray(written, dtype=bool)
    labels, count = ndimage.label(~written, structure=np.ones((3, 3), dtype=int))
    border = np.unique(np.concatenate((labels[0], labels[-1], labels[:, 0], labels[:, -1])))
    grid = written.copy()
    for patch in np.setdiff1d(np.arange(1, count + 1), border):
        trial = grid | (labels == patch)
        if np.array_equal(written_cells(trial), written):
            grid = trial
    return grid


def wall_cells() -> list[tuple[int, int]]:
    """The 96 (row, column) cells of the start box below the grid: side walls on rows 0 and
    29 over columns -34..-1, and the floor, column -34, between them."""
    cols = range(-CORRIDOR_COLUMNS, 0)
    sides = [(r, c) for r in (0, GRID_SIZE - 1) for c in cols]
    floor = [(r, -CORRIDOR_COLUMNS) for r in range(1, GRID_SIZE - 1)]
    return sides + floor


def cell_center(row: int, col: int) -> tuple[float, float]:
    """Centre (x, y) of lattice cell (row, col), m: the exact decimal BARN's files write."""
    return (
        (ORIGIN_MM[0] + CELL_MM * row) / 1000.0,
        (ORIGIN_MM[1] + CELL_MM * col) / 1000.0,
    )


def barn_cylinders(grid: np.ndarray) -> tuple[Cylinder, ...]:
    """The cylinders of a BARN world: the grid's written cells, then the start box.

    grid: (30, 30) bool. Returns cylinders of radius 0.075 m, ordered by (row, column).
    """
    rows, cols = np.nonzero(written_cells(grid))
    cells = [(int(r), int(c)) for r, c in zip(rows, cols, strict=True)] + wall_cells()
    return tuple(Cylinder(center=cell_center(r, c), radius=RADIUS, height=HEIGHT) for r, c in cells)


def path_points(path: np.ndarray) -> np.ndarray:
    """BARN's reference path as a polyline, m: (K + 2, 2) float64, start, the K cells mapped
    as run.py maps them, then the goal. path: (K, 2) int cells (px, py)."""
    cells = np.asarray(path, dtype=np.float64)
    xy = cells * PATH_SCALE + np.asarray(PATH_OFFSET)
    return np.vstack((START[:2], xy, GOAL))


def path_length(path: np.ndarray) -> float:
    """Length of BARN's reference polyline (:func:`path_points`), m."""
    steps = np.diff(path_points(path), axis=0)
    return float(np.hypot(steps[:, 0], steps[:, 1]).sum())


def barn_split(index: int) -> str:
    """``challenge`` for worlds 0, 6, ..., 294, else ``train``."""
    return "challenge" if check_index(index) % CHALLENGE_STEP == 0 else "train"


def barn_split_ids(split: str) -> tuple[int, ...]:
    """The world numbers of a split (:data:`SPLITS`), ascending."""
    if split not in SPLITS:
        raise UnknownNameError(f"unknown BARN split {split!r}: choose from {', '.join(SPLITS)}")
    ids = range(BARN_WORLDS)
    return tuple(i for i in ids if split == "all" or barn_split(i) == split)


def barn_selection(
    split: str, ids: str | None = None, option: str = "--world-ids"
) -> tuple[int, ...]:
    """The worlds of ``split``, or the subset ``ids`` of it ('0,6,12', ranges as '0-30' mix
    in), in the order given. ConfigError naming ``option`` for an empty list, a number that is
    not a BARN world, a repeat, or a world outside the split."""
    members = barn_split_ids(split)
    if ids is None:
        return members
    chosen: list[int] = []
    for part in (p.strip() for p in ids.split(",") if p.strip()):
        match = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
        if match is None or (match[2] is not None and int(match[2]) < int(match[1])):
            raise ConfigError(f"{option}: {part!r} is not a world number or a range like 0-30")
        lo, hi = int(match[1]), int(match[2] or match[1])
        if hi >= BARN_WORLDS:
            raise ConfigError(f"{option}: {hi} is not a BARN world (0..{BARN_WORLDS - 1})")
        chosen += range(lo, hi + 1)
    if not chosen:
        raise ConfigError(f"{option} is empty: name at least one world, or leave it out")
    if len(set(chosen)) != len(chosen):
        raise ConfigError(f"{option}: {ids!r} names a world twice")
    outside = [i for i in chosen if i not in members]
    if outside:
        shown = ", ".join(map(str, outside[:5])) + (", ..." if len(outside) > 5 else "")
        raise ConfigError(
            f"{option}: world(s) {shown} not in the {split} split; choose --split all or "
            f"{'train' if split == 'challenge' else 'challenge'}"
        )
    return tuple(chosen)


def barn_name(index: int) -> str:
    """The world name of BARN world ``index``: ``BARN-<index>``."""
    return f"BARN-{check_index(index)}"


def check_index(index: int) -> int:
    """``index`` if it names a BARN world (0..299), else UnknownNameError."""
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise UnknownNameError(f"BARN world number must be an integer, got {index!r}")
    if not 0 <= index < BARN_WORLDS:
        raise UnknownNameError(
            f"unknown BARN world {index}: BARN worlds are numbered 0..{BARN_WORLDS - 1}"
        )
    return int(index)


def world_file(index: int) -> Path:
    """The package-data file of BARN world ``index``."""
    return barn_dir() / f"world_{check_index(index)}.txt"


@cache
def _manifest(folder: Path) -> dict[str, str]:
    """SHA-256 (hex) of every file in the folder's SHA256SUMS, by file name."""
    path = folder / MANIFEST
    if not path.is_file():
        raise InstallError(f"{path}: missing BARN manifest; reinstall d3dwa-bullet")
    sums = {}
    for n, line in enumerate(path.read_text(encoding="ascii").splitlines(), 1):
        parts = line.split()
        if len(parts) != 2 or not re.fullmatch(r"[0-9a-f]{64}", parts[0]):
            raise WorldFormatError(f"{path}:{n}: expected '<sha256>  <file>', got {line!r}")
        sums[parts[1]] = parts[0]
    return sums


def read_world_file(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(grid (30, 30) bool, path (K, 2) int64) of a BARN world file, checked against the
    manifest beside it: WorldFormatError names the file and both checksums on a mismatch."""
    if not path.is_file():
        raise InstallError(f"{path}: missing BARN world file; reinstall d3dwa-bullet")
    data = path.read_bytes()
    expected = _manifest(path.parent).get(path.name)
    actual = hashlib.sha256(data).hexdigest()
    if expected != actual:
        raise WorldFormatError(
            f"{path}: sha256 {actual} does not match {MANIFEST} ({expected or 'no entry'}); "
            "the file was changed or truncated, reinstall d3dwa-bullet"
        )
    return parse_world_text(data.decode("ascii"), str(path))


def parse_world_text(text: str, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(grid, path) from a world file's text: '#' comment lines, 30 grid rows of 30 '0'/'1'
    characters, then one 'px py' line per reference path cell."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    rows, cells = lines[:GRID_SIZE], lines[GRID_SIZE:]
    if len(rows) < GRID_SIZE or any(not re.fullmatch(r"[01]{30}", r) for r in rows):
        raise WorldFormatError(f"{source}: expected {GRID_SIZE} grid rows of 30 '0'/'1'")
    grid = np.array([[ch == "1" for ch in r] for r in rows], dtype=bool)
    if not cells or any(not re.fullmatch(r"\d+ \d+", c) for c in cells):
        raise WorldFormatError(f"{source}: expected reference path lines 'px py' after the grid")
    path = np.array([[int(v) for v in c.split()] for c in cells], dtype=np.int64)
    return grid, path


def barn_world(index: int) -> World:
    """BARN world ``index`` (0..299) with BARN's task and its reference path length."""
    index = check_index(index)
    path_file = world_file(index)
    grid, path = read_world_file(path_file)
    split = barn_split(index)
    world = World(
        name=barn_name(index),
        description=f"BARN world {index} ({split} split), the-barn-challenge (MIT)",
        start=START,
        goal=GOAL,
        obstacles=barn_cylinders(grid),
        group=SPLIT_GROUPS[split],
        time_limit=TIME_LIMIT,
        source=f"barn:{index}",
        reference_length=path_length(path),
    )
    validate_task(world)
    return world


def barn_index(name: str) -> int | None:
    """The number of the BARN world a name such as ``BARN-17`` (any case) names, or None if
    the name is not of that form; UnknownNameError if its number is out of range."""
    match = _NAME.fullmatch(name.strip())
    return None if match is None else check_index(int(match.group(1)))


def barn_world_from_name(name: str) -> World | None:
    """The BARN world a name such as ``BARN-17`` (any case) names, or None (see barn_index)."""
    index = barn_index(name)
    return None if index is None else barn_world(index)
