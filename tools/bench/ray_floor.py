"""What the lidar's ray batch costs on BARN, and what can be cut from it without changing a range (issue 78).

At fixed poses on each BARN world (``--poses`` along the straight line from start to goal, headings
drawn from ``--seed``), one ``rayTestBatch`` of the lidar's 481 beams is timed in process CPU time
(every thread counted), the variants interleaved in each of ``--repeats`` rounds, the median kept:

- ``threads_1``: the batch on the caller's thread, as a pool worker casts it;
- ``threads_0``: Bullet's thread pool over every core (a single process's default before 2026-12-07);
- ``robot_filtered``: ``collisionFilterMask`` = Bullet's static filter, so no beam is tested against the
  robot's own links (it cannot hit them: the lidar sits above the body);
- ``cut_at_hit``: each beam ends 1 cm past its own first hit (misses keep ``range_max``). Not a way
  to cast (the hit fraction is then of another segment, so the range differs in its last bits), but
  the cost of a walk that stopped at the first hit: Bullet's BVH walk tests every triangle the
  whole ray crosses (its ``lambda_max`` is never lowered by a hit), and this is the part past the hit.

``same_ranges`` says, per world, whether ``threads_0`` and ``robot_filtered`` gave every beam's
range equal to ``threads_1``'s, bit for bit::

    python -m tools.bench.ray_floor --json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pybullet as pb

from d3dwa_bullet.robot import AXLE_HEIGHT
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main

STATIC_FILTER = 2
"""Bullet's ``btBroadphaseProxy::StaticFilter``: the group PyBullet gives a fixed-base body (the
ground and the obstacles' mesh); the robot, dynamic, is in ``DefaultFilter`` (1)."""


def poses(world_name: str, count: int, seed: int) -> list[tuple[list[float], tuple[float, ...]]]:
    """count robot poses (position m, quaternion) on the line start -> goal, headings uniform."""
    world = load_world(world_name)
    (x, y, _), (gx, gy) = world.start, world.goal
    rng = np.random.default_rng(seed)
    out = []
    for f in np.linspace(0.0, 1.0, count):
        yaw = float(rng.uniform(-math.pi, math.pi))
        out.append(
            (
                [x + f * (gx - x), y + f * (gy - y), AXLE_HEIGHT],
                pb.getQuaternionFromEuler([0, 0, yaw]),
            )
        )
    return out


def world_floor(world_name: str, count: int, seed: int, repeats: int) -> dict[str, Any]:
    """Median CPU µs per scan of each variant on one world, and whether the ranges stayed equal."""
    at = poses(world_name, count, seed)
    with Simulator(load_world(world_name)) as sim:
        lidar, cid = sim.lidar, sim.client
        range_max = lidar.params.range_max

        def cast(to: list[list[list[float]]], **kw: int) -> list[np.ndarray]:
            out = []
            for (pos, orn), to_k in zip(at, to, strict=True):
                pb.resetBasePositionAndOrientation(sim.robot, pos, orn, physicsClientId=cid)
                hits = pb.rayTestBatch(lidar._from, to_k, parentObjectUniqueId=lidar.robot,
                                       parentLinkIndex=lidar.link, physicsClientId=cid, **kw)  # fmt: skip
                out.append(np.array([h[2] for h in hits]))
            return out

        full = [lidar._to] * len(at)
        reference = cast(full, numThreads=1)
        unit = np.asarray(lidar._to) / range_max
        cut = [
            (unit * np.where(f < 1.0, f * range_max + 0.01, range_max)[:, None]).tolist()
            for f in reference
        ]
        variants: dict[str, Callable[[], list[np.ndarray]]] = {
            "threads_1": lambda: cast(full, numThreads=1),
            "threads_0": lambda: cast(full, numThreads=0),
            "robot_filtered": lambda: cast(full, numThreads=1, collisionFilterMask=STATIC_FILTER),
            "cut_at_hit": lambda: cast(cut, numThreads=1),
        }
        times: dict[str, list[float]] = {name: [] for name in variants}
        same = True
        for _ in range(repeats):
            for name, run in variants.items():
                start = time.process_time()
                got = run()
                times[name].append((time.process_time() - start) / len(at))
                if name in ("threads_0", "robot_filtered"):
                    same = same and all(
                        np.array_equal(a, b) for a, b in zip(got, reference, strict=True)
                    )
    hit = np.concatenate(reference) < 1.0
    us = {name: round(1e6 * float(np.median(t)), 1) for name, t in times.items()}
    return {"world": world_name, "poses": len(at), "beams_hit": round(float(hit.mean()), 3),
            "us_per_scan": us, "same_ranges": same,
            "past_first_hit": round(1.0 - us["cut_at_hit"] / us["threads_1"], 3)}  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default="BARN-0,BARN-150", help="comma list (default %(default)s)")
    ap.add_argument("--poses", type=int, default=60, help="poses per world (default %(default)s)")
    ap.add_argument(
        "--repeats", type=int, default=7, help="interleaved rounds (default %(default)s)"
    )
    ap.add_argument("--seed", type=int, default=0, help="the headings' seed (default %(default)s)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.poses < 1 or args.repeats < 1:
        ap.error(f"--poses and --repeats must be >= 1, got {args.poses} and {args.repeats}")
    names = [w for w in args.worlds.split(",") if w]
    if not names:
        ap.error("--worlds is empty")
    rows = [world_floor(name, args.poses, args.seed, args.repeats) for name in names]
    if args.json:
        print(json.dumps(rows))
        return
    for r in rows:
        print(f"{r['world']}: {r['us_per_scan']} µs per scan; same ranges {r['same_ranges']}; "
              f"{100 * r['past_first_hit']:.0f} % of the batch is past the first hit")  # fmt: skip


if __name__ == "__main__":
    raise SystemExit(main())
