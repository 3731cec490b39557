"""A tiny policy trained in seconds (30 steps, an 8-unit network): for tests about what a
policy's files record (its BARN training worlds, say), never about what it learned."""

from __future__ import annotations

from pathlib import Path

from d3dwa_bullet.learning.agents.d3qn import D3QNConfig
from d3dwa_bullet.learning.training import TrainConfig, train
from d3dwa_bullet.learning.training.run_dir import POLICY_DIR


def tiny_run(out: Path, **changes) -> Path:
    """Train a 30-step ``d3dwa`` run into ``out`` (no worlds, no generators unless ``changes``
    give some, e.g. ``barn_split="train", barn_worlds=5``); returns its policy folder."""
    config = TrainConfig(
        **(
            dict(
                method="d3dwa",
                total_steps=30,
                worlds=(),
                generators=(),
                agent=D3QNConfig(hidden=(8,), batch_size=4, buffer_size=100, learning_starts=10),
                eval_every=0,
                checkpoint_every=0,
                log_every=10,
                keep="final",
                n_envs=1,
                vector="sync",
            )
            | changes
        )
    )
    train(config, out, progress=False)
    return out / POLICY_DIR
