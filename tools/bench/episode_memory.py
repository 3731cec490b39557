"""Benchmark what an evaluation worker's memory does over many episodes: the resident size of
one process after each of ``--episodes`` dwa3 episodes, cycling over ``--worlds``, with the
obstacle mesh cached per world (as every command runs) and, for comparison in the same run, in a
second process that builds it anew every episode (as before the cache).

    python -m tools.bench.episode_memory
    python -m tools.bench.episode_memory --worlds BARN-0,BARN-6 --episodes 8 --json

PyBullet keeps a reference to every item of the vertex and index lists a mesh is made from;
lists built anew each episode are never freed (docs/benchmarks.md#memory). The figure to read is
the growth per episode after every world has been seen once: about zero with the cache.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from collections.abc import Sequence

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.sim import simulator
from d3dwa_bullet.world.registry import load_world
from tools.entry import ToolParser, tool_main


def resident_mb() -> float:
    """This process's resident set size, MB (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


def run(worlds: Sequence[str], episodes: int, fresh: bool) -> list[float]:
    """Resident MB after each episode; ``fresh`` empties the mesh cache before every one."""
    loaded = [load_world(w) for w in worlds]
    sizes = []
    for i in range(episodes):
        if fresh:
            simulator.obstacle_mesh.cache_clear()
        run_episode(loaded[i % len(loaded)], make_controller("dwa3"), seed=0)
        sizes.append(resident_mb())
    return sizes


def _child(args: tuple[Sequence[str], int, bool]) -> list[float]:
    return run(*args)


def growth(sizes: Sequence[float], worlds: int) -> float:
    """MB per episode after the first pass over the worlds (0 when there is no second pass)."""
    later = sizes[worlds - 1 :]
    return (later[-1] - later[0]) / (len(later) - 1) if len(later) > 1 else 0.0


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default="BARN-0,BARN-6,BARN-12", help="comma-separated worlds")
    ap.add_argument("--episodes", type=int, default=9, help="episodes per process")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    worlds = [w.strip() for w in args.worlds.split(",") if w.strip()]
    if not worlds:
        ap.error(f"--worlds names no world: {args.worlds!r}")
    if args.episodes < len(worlds) + 1:
        ap.error(f"--episodes must be above the {len(worlds)} worlds, got {args.episodes}")
    for w in worlds:
        load_world(w)  # an unknown world is refused before any episode
    ctx = multiprocessing.get_context("spawn")  # each side in a fresh process of its own
    with ctx.Pool(1) as pool:
        cached = pool.apply(_child, ((worlds, args.episodes, False),))
    with ctx.Pool(1) as pool:
        fresh = pool.apply(_child, ((worlds, args.episodes, True),))
    out = {
        "worlds": worlds,
        "episodes": args.episodes,
        "cached_mb": cached,
        "fresh_mb": fresh,
        "cached_mb_per_episode": growth(cached, len(worlds)),
        "fresh_mb_per_episode": growth(fresh, len(worlds)),
    }
    if args.json:
        print(json.dumps(out, indent=1))
        return
    for label, sizes in (("mesh cached", cached), ("mesh anew", fresh)):
        print(f"{label:>11}: " + " ".join(f"{s:.0f}" for s in sizes) + " MB resident")
    print(
        f"after the first pass over {len(worlds)} worlds: {out['cached_mb_per_episode']:+.1f} MB "
        f"an episode with the cache, {out['fresh_mb_per_episode']:+.1f} MB built anew"
    )


if __name__ == "__main__":
    raise SystemExit(main())
