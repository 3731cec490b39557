"""Every learned method ships a policy in policies/, loading with its method's action set and
choosing the recorded greedy actions (so swapped, retrained or altered weights are caught)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.methods import LEARNED, default_policy_path, make_controller

OBSERVATIONS = np.array(
    [
        [0.5, 0.1, 0.2, 0.0] + [0.6] * 8,
        [0.9, 0.0, 0.0, 0.0] + [1.0] * 8,
        [0.2, -0.6, 0.5, 0.1, 0.2, 0.3, 1.0, 1.0, 1.0, 1.0, 0.4, 0.1],
        [0.7, 0.8, 0.3, -0.2, 1.0, 0.9, 0.3, 0.15, 0.3, 0.9, 1.0, 1.0],
        [0.4, -0.2, 0.8, -0.5, 0.9, 0.2, 0.1, 0.5, 1.0, 1.0, 1.0, 0.7],
        [0.1, 0.9, 0.0, 0.3] + [0.8] * 8,
    ]
)
"""Fixed observations [d_g, theta_g, v, w, l_1..l_8]; for every shipped policy each one's best
action beats the runner-up by > 2e-3 (no near-ties that float rounding could flip)."""

GOLDEN_ACTIONS = {
    "d3dwa": [42, 17, 35, 44, 92, 18],
    "d3dwa-weights": [11, 0, 19, 20, 19, 18],
    "d3dwa-dr": [43, 36, 42, 42, 67, 98],
    "dqdwa": [10, 2, 22, 15, 1, 22],
}
"""Greedy action index of each shipped policy for each of OBSERVATIONS, recorded from the
weights in policies/. After shipping a new policy on purpose, regenerate them with
``python tests/learning/test_shipped_policies.py`` and paste its output here."""


def greedy_actions(method: str) -> list[int]:
    """The shipped policy's greedy action index for each of OBSERVATIONS."""
    policy, _, _ = load_policy(default_policy_path(method), expected_actions=LEARNED[method])
    return [int(policy(obs)) for obs in OBSERVATIONS]


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


@pytest.mark.parametrize("method", list(LEARNED))
def test_shipped_policy_chooses_the_recorded_actions(method: str) -> None:
    assert set(GOLDEN_ACTIONS) == set(LEARNED)
    assert greedy_actions(method) == GOLDEN_ACTIONS[method]
    controller = make_controller(method)  # what evaluation runs: the same shipped weights
    assert [controller(obs)[0] for obs in OBSERVATIONS] == GOLDEN_ACTIONS[method]


if __name__ == "__main__":
    print("GOLDEN_ACTIONS = {")
    for name in LEARNED:
        print(f"    {name!r}: {greedy_actions(name)},")
    print("}")
