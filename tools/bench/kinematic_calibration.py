"""Fit the kinematic backend's rolling radius and track to PyBullet's paths, and say why.

    python -m tools.bench.kinematic_calibration
    python -m tools.bench.kinematic_calibration --sequences 4 --json

PyBullet loads the URDF's wheel cylinders as convex hulls (collision geometry type 5, a mesh)
with a 1 mm collision margin (``getDynamicsInfo``); the tool prints both. Then ``--sequences``
random command sequences (seeded 0, 1, ...: about 30 commands each, held 2-7 periods, 60 % of
them turning) drive the robot in an empty world in PyBullet and, for each (radius, track) of a
grid, in the kinematic backend; the figure is the mean distance between the two paths, mm, over
every control step. ``sim/kinematic.py`` takes the best pair of the grid.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from d3dwa_bullet.resources import urdf_path
from d3dwa_bullet.sim import kinematic
from d3dwa_bullet.sim.bullet import p
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.model import World
from tools.entry import ToolParser, tool_main

EMPTY = World("empty", "no obstacles", (0.0, 0.0, 0.0), (50.0, 0.0))
RADII = (0.045, 0.0455, 0.046, 0.0465)
TRACKS = (0.2, 0.2033, 0.2067, 0.21, 0.2133, 0.2167)


def wheel_shape() -> dict[str, float | int]:
    """The left wheel's collision geometry type and margin as PyBullet loaded it."""
    cid = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(urdf_path()), physicsClientId=cid)
        geometry = p.getCollisionShapeData(robot, 0, physicsClientId=cid)[0][2]
        margin = p.getDynamicsInfo(robot, 0, physicsClientId=cid)[11]
    finally:
        p.disconnect(physicsClientId=cid)
    return {
        "geometry_type": int(geometry),
        "is_mesh": geometry == p.GEOM_MESH,
        "margin_m": float(margin),
    }


def straight_ratios(speeds: Sequence[float] = (0.1, 0.2, 0.3, 0.4)) -> dict[str, float]:
    """PyBullet's forward speed over the commanded one on a straight run, per speed (m/s): the
    distance covered in 5 s after 3 s to settle, over speed * 5 s."""
    out = {}
    for v in speeds:
        with Simulator(EMPTY) as bullet:
            for _ in range(30):
                bullet.step(v, 0.0)
            x0 = np.array(bullet.true_pose()[:2])
            for _ in range(50):
                bullet.step(v, 0.0)
            out[f"{v:g}"] = float(np.hypot(*(np.array(bullet.true_pose()[:2]) - x0)) / (5.0 * v))
    return out


def sequence(seed: int) -> list[tuple[float, float]]:
    """A random command sequence: (v m/s, w rad/s) per control period."""
    rng = np.random.default_rng(seed)
    out: list[tuple[float, float]] = []
    for _ in range(30):
        v, w = rng.uniform(0.0, 0.4), rng.uniform(-2.0, 2.0) * (rng.random() < 0.6)
        out += [(v, w)] * int(rng.integers(2, 8))
    return out


def path(sim, commands: list[tuple[float, float]]) -> np.ndarray:
    """(steps, 2) base_link positions after each command, m."""
    out = []
    for c in commands:
        sim.step(*c)
        out.append(sim.true_pose()[:2])
    return np.asarray(out)


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=4, help="random command sequences (>= 1)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.sequences < 1:
        ap.error(f"--sequences must be >= 1, got {args.sequences}")
    seqs = [sequence(s) for s in range(args.sequences)]
    refs = []
    for commands in seqs:
        with Simulator(EMPTY) as bullet:
            refs.append(path(bullet, commands))
    saved = kinematic.ROLLING_RADIUS, kinematic.EFFECTIVE_TRACK
    grid = []
    try:
        for radius in RADII:
            for track in TRACKS:
                kinematic.ROLLING_RADIUS, kinematic.EFFECTIVE_TRACK = radius, track
                err = [np.hypot(*(path(kinematic.KinematicSimulator(EMPTY), c) - r).T).mean()
                       for c, r in zip(seqs, refs, strict=True)]  # fmt: skip
                grid.append(
                    {
                        "radius_m": radius,
                        "track_m": track,
                        "mean_error_mm": 1e3 * float(np.mean(err)),
                    }
                )
    finally:
        kinematic.ROLLING_RADIUS, kinematic.EFFECTIVE_TRACK = saved
    grid.sort(key=lambda g: g["mean_error_mm"])
    nominal = next(g for g in grid if g["radius_m"] == 0.045 and g["track_m"] == 0.2)
    result: dict[str, Any] = {"wheel": wheel_shape(), "straight_speed_ratio": straight_ratios(), "best": grid[0], "nominal": nominal, "in_use":
              {"radius_m": saved[0], "track_m": saved[1]}, "grid": grid}  # fmt: skip
    if args.json:
        print(json.dumps(result, indent=1))
        return
    w, b = result["wheel"], grid[0]
    ratios = ", ".join(f"{k} m/s {r:.3f}" for k, r in result["straight_speed_ratio"].items())
    print(f"PyBullet's speed over the commanded one, straight: {ratios}")
    print(
        f"PyBullet's wheel: geometry type {w['geometry_type']} (mesh: {w['is_mesh']}), margin {w['margin_m']} m"
    )
    print(f"best of the grid: radius {b['radius_m']} m, track {b['track_m']} m: {b['mean_error_mm']:.1f} mm mean "
          f"path error; the URDF's 0.045 / 0.2: {nominal['mean_error_mm']:.1f} mm")  # fmt: skip
    print(f"in use (sim/kinematic.py): radius {saved[0]} m, track {saved[1]} m")


if __name__ == "__main__":
    raise SystemExit(main())
