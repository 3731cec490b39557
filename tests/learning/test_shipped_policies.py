"""Every learned method ships a policy in policies/, loading with its method's action set."""

from __future__ import annotations

import json

import numpy as np
import pytest

from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.training.trainer import load_train_config
from d3dwa_bullet.methods import LEARNED, default_policy_path, make_controller


@pytest.mark.parametrize("method", list(LEARNED))
def test_shipped_policy_loads_with_its_action_set(method: str) -> None:
    path = default_policy_path(method)
    assert path.is_dir(), f"no shipped policy in {path}"
    policy, actions, meta = load_policy(path, expected_actions=LEARNED[method])
    assert meta["method"] == method and actions.size == LEARNED[method].size
    assert meta["agent"] == ("dqdwa" if method == "dqdwa" else "d3qn")
    names = {p.name for p in path.iterdir()}
    assert {"meta.json", "config.json", "learning_curve.png"} <= names
    assert not names & {"replay.npz", "training_state.json", "training_state.pt"}
    assert load_train_config(path / "config.json").method == method
    assert set(json.loads((path / "meta.json").read_text())["files"]) <= names
    obs = np.array([0.5, 0.1, 0.2, 0.0] + [0.6] * 8)
    assert 0 <= policy(obs) < actions.size
    controller = make_controller(method)
    index, action = controller(obs)
    assert action == actions.decode(index)
