"""Make the BARN package data (``d3dwa_bullet/data/barn/``) from a clone of the-barn-challenge.

A developer tool, run once: it reads BARN's 300 Gazebo worlds and reference paths from a git
directory of github.com/Daffan/the-barn-challenge (MIT licence, (c) 2022 Zifan Xu), recovers
each world's 30x30 occupancy grid from its cylinders, checks that rebuilding the world from
the grid gives back the file's cylinders exactly, and writes one small text file per world
(grid rows, then the path cells), the licence, a README and a SHA256SUMS manifest::

    python -m tools.barn_convert /work/.mirror/Daffan+the-barn-challenge/repo

Any world that does not rebuild exactly stops the run with one line naming it.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import subprocess
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.errors import ConfigError, WorldFormatError
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.world.barn import (
    BARN_WORLDS,
    CELL_MM,
    GRID_SIZE,
    HEIGHT,
    MANIFEST,
    ORIGIN_MM,
    RADIUS,
    barn_cylinders,
    path_length,
    recover_grid,
)
from d3dwa_bullet.world.sdf import load_sdf_world
from tools.entry import ToolParser, tool_main

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "d3dwa_bullet" / "data" / "barn"
WORLDS = "jackal_helper/worlds/BARN"
REPO_URL = "https://github.com/Daffan/the-barn-challenge"


def git(repo: Path, *args: str) -> bytes:
    """Output of a git command run on the bare repository ``repo``; ConfigError with git's
    own first line when it fails (not a git directory, a missing file)."""
    done = subprocess.run(["git", "-C", str(repo), *args], capture_output=True)
    if done.returncode != 0:
        first = (done.stderr.decode(errors="replace").strip().splitlines() or ["failed"])[0]
        raise ConfigError(f"{repo}: git {' '.join(args)}: {first}")
    return done.stdout


def cylinder_key(center: tuple[float, float], radius: float, height: float) -> tuple:
    return (center[0], center[1], radius, height)


def written_from_world(world_text: bytes, where: str) -> tuple[np.ndarray, set[tuple]]:
    """(written cells (30, 30) bool, the file's cylinder keys) of one .world file."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "world.world"
        path.write_bytes(world_text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the ground plane and light are not obstacles
            world = load_sdf_world(path)
    keys = set()
    written = np.zeros((GRID_SIZE, GRID_SIZE), dtype=bool)
    for ob in world.obstacles:
        radius, height = getattr(ob, "radius", None), ob.height
        if radius != RADIUS or height != HEIGHT:
            raise WorldFormatError(f"{where}: obstacle {ob} is not a BARN cylinder")
        row = round((ob.center[0] * 1000 - ORIGIN_MM[0]) / CELL_MM)
        col = round((ob.center[1] * 1000 - ORIGIN_MM[1]) / CELL_MM)
        if 0 <= row < GRID_SIZE and 0 <= col < GRID_SIZE:
            written[row, col] = True
        keys.add(cylinder_key(ob.center, radius, height))
    if len(keys) != len(world.obstacles):
        raise WorldFormatError(f"{where}: duplicate cylinders")
    return written, keys


def world_text(index: int, grid: np.ndarray, path: np.ndarray) -> str:
    head = (
        f"# BARN world {index}, from {REPO_URL} (MIT licence, see LICENSE)\n"
        "# grid: 30 rows r (x = -4.425 + 0.15 r m) of 30 columns c (y = 5.175 + 0.15 c m), "
        "1 = filled\n"
    )
    rows = "".join("".join("1" if v else "0" for v in row) + "\n" for row in grid)
    cells = "".join(f"{int(px)} {int(py)}\n" for px, py in path)
    return head + rows + f"# path: the {len(path)} cells (px, py) of path_{index}.npy\n" + cells


def convert(repo: Path, out: Path) -> list[float]:
    """Write every world file into ``out``; returns the reference path lengths, m."""
    commit = git(repo, "rev-parse", "HEAD").decode().strip()
    lengths = []
    for i in range(BARN_WORLDS):
        where = f"{WORLDS}/world_{i}.world"
        written, keys = written_from_world(git(repo, "show", f"HEAD:{where}"), where)
        grid = recover_grid(written)
        rebuilt = {cylinder_key(c.center, c.radius, c.height) for c in barn_cylinders(grid)}
        if rebuilt != keys:
            raise WorldFormatError(
                f"{where}: rebuilt cylinders differ from the file's "
                f"({len(rebuilt - keys)} extra, {len(keys - rebuilt)} missing)"
            )
        path = np.load(io.BytesIO(git(repo, "show", f"HEAD:{WORLDS}/path_files/path_{i}.npy")))
        if path.ndim != 2 or path.shape[1] != 2 or path.dtype.kind != "i":
            raise WorldFormatError(f"path_{i}.npy: expected (K, 2) integers, got {path.shape}")
        if grid[path[:, 0], path[:, 1]].any():
            raise WorldFormatError(f"path_{i}.npy: a path cell lies on a filled grid cell")
        atomic_write_text(out / f"world_{i}.txt", world_text(i, grid, path))
        lengths.append(path_length(path))
    atomic_write_text(out / "LICENSE", git(repo, "show", "HEAD:LICENSE").decode())
    atomic_write_text(out / "README.md", readme(commit, lengths))
    names = sorted(p.name for p in out.iterdir() if p.is_file() and p.name != MANIFEST)
    sums = "".join(f"{hashlib.sha256((out / n).read_bytes()).hexdigest()}  {n}\n" for n in names)
    atomic_write_text(out / MANIFEST, sums)
    return lengths


def readme(commit: str, lengths: list[float]) -> str:
    return f"""# BARN worlds, as grids and reference paths

The 300 static worlds of BARN (Benchmark for Autonomous Robot Navigation), from
{REPO_URL}
at commit {commit}, `{WORLDS}/`.
MIT licence, (c) 2022 Zifan Xu: the notice is in `LICENSE` beside this file.

`world_N.txt` holds world N's 30x30 occupancy grid (row r at x = -4.425 + 0.15 r m, column c at
y = 5.175 + 0.15 c m, `1` filled), recovered from the cylinders of `world_N.world`, then the
cells of `path_files/path_N.npy` unchanged, one `px py` line each. `d3dwa_bullet.world.barn`
rebuilds each world from its grid; the rebuilt cylinders equal the `.world` file's exactly.
Reference path lengths: {min(lengths):.2f}-{max(lengths):.2f} m.
`SHA256SUMS` covers every file here; a world file is read only if it matches.

Made by `tools/barn_convert.py`; see docs/worlds.md (BARN).
"""


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("repo", type=Path, help="git directory of the-barn-challenge")
    ap.add_argument("--out", type=Path, default=OUT, help="output folder (default: %(default)s)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    lengths = convert(args.repo, args.out)
    print(
        f"wrote {len(lengths)} worlds to {args.out}: path lengths "
        f"{min(lengths):.2f}-{max(lengths):.2f} m (median {float(np.median(lengths)):.2f})"
    )


if __name__ == "__main__":
    raise SystemExit(main())
