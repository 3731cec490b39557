"""Issue 78's overheads change no episode: one BARN episode of a learned policy under the harsh
profile with the recovery layer, digested (its result row, every per-step log column, every
observation), equals the digest recorded from the code at 9fc0444, before the torch-free policy,
the one-thread ray batch and the compiled clearance metric (docs/design/episode-cost.md)."""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, run_episode
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.params import RecoveryParams
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.world.barn import barn_world

RECORDED_AT_9FC0444 = "da1005e66805a8ddaf3cd8f0836f3c107cdd9f30fc59ecb9a2c1e46e39a1f75f"
"""sha256 of ``episode_digest()`` as the code at 9fc0444 computed it (tools/bench/episode_cost.py
compares whole sweeps the same way)."""


def episode_digest() -> str:
    """sha256 over the row, the log and the observations of one 8 s episode: BARN world 150,
    d3dwa (shipped seed 0), harsh noise, seed 3, the nav2 recovery layer."""
    world = dataclasses.replace(barn_world(150), time_limit=8.0)
    result = run_episode(
        world, make_controller("d3dwa", policies_dir() / "d3dwa" / "seed-0"), seed=3,
        noise=make_noise("harsh", 3), noise_name="harsh", config=EpisodeConfig(recovery=RecoveryParams()),
    )  # fmt: skip
    h = hashlib.sha256(repr(sorted(result.summary().items())).encode())
    for name in sorted(result.log):
        h.update(name.encode())
        h.update(np.ascontiguousarray(result.log[name]).tobytes())
    h.update(np.ascontiguousarray(result.observations).tobytes())
    return h.hexdigest()


def test_episode_equals_the_branch_point():
    assert episode_digest() == RECORDED_AT_9FC0444


if __name__ == "__main__":
    print(episode_digest())
