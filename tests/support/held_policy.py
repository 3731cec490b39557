"""A fresh D3QN checkpoint that records a decision period and a training recovery layer, as a
run trained with ``decision_steps`` and ``recovery`` would (docs/design/agent.md#decision-period)."""

from __future__ import annotations

from pathlib import Path

from d3dwa_bullet.learning.agents.checkpoint import save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.observation_kinds import observation_layout


def held_checkpoint(
    directory: Path,
    decision_steps: object = 10,
    recovery: object = "nav2",
    seed: int = 1,
    scan_filter: object = None,
) -> Path:
    """An untrained ``d3dwa`` network (hidden 16) saved with metadata ``decision_steps`` and
    ``recovery`` (any JSON value, so tests can record bad ones), and ``scan_filter`` unless
    None (then unrecorded, as before filters were). Seed 1's greedy action changes several
    times in R1's first 3 s, so holding it changes what the robot does."""
    agent = D3QNAgent(
        ACTIONS_FULL, D3QNConfig(hidden=(16,), seed=seed), observation_layout("paper")
    )
    metadata = {"decision_steps": decision_steps, "recovery": recovery}
    if scan_filter is not None:
        metadata["scan_filter"] = scan_filter
    return save_checkpoint(directory, agent, metadata=metadata, method="d3dwa")
