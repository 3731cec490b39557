"""The torch checkpoint's greedy policy checks every decision's Q-values are numbers, as the
ONNX runner does (issue 42, leftovers): a NaN observation, or weights that overflow on an
observation, is one line naming the checkpoint, never an action chosen from NaN."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.policy import greedy_policy, load_policy
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from tests.support.held_policy import held_checkpoint


def test_a_nan_observation_is_refused_naming_the_checkpoint(tmp_path):
    folder = held_checkpoint(tmp_path / "p", decision_steps=1, recovery="none")
    policy, _, _ = load_policy(folder)
    obs = np.full(12, 0.5, dtype=np.float32)
    assert 0 <= policy(obs) < ACTIONS_FULL.size
    obs[3] = np.nan
    with pytest.raises(CheckpointError) as err:
        policy(obs)
    message = str(err.value)
    assert "\n" not in message and str(folder) in message and "NaN or inf" in message


def test_weights_that_overflow_are_refused_at_the_decision():
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(8,), seed=0))
    with torch.no_grad():
        for p in agent.online.parameters():
            p.fill_(3e38)  # finite float32, but the first product overflows to inf
    with pytest.raises(CheckpointError, match="NaN or inf"):
        greedy_policy(agent, "big")(np.ones(12, dtype=np.float32))
