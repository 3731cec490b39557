"""Every learned method ships five or more training seeds in policies/<method>/seed-<k>/, each
loading with its method's action set, carrying its config, learning curve and run summary,
all trained under one config, and choosing the recorded greedy actions (so swapped,
retrained or altered weights are caught)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from d3dwa_bullet.evaluation.policy_runs import check_one_experiment
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.methods import LEARNED, default_policy_path, make_controller, method_observation
from d3dwa_bullet.seed_dirs import seed_dirs

MIN_SEEDS = 5
"""The learning protocol's minimum (docs/design.md#learning-protocol)."""
SHORT_OF_TARGET: dict[str, int] = {}
"""Methods whose remaining seeds are still training (resumable with --resume), with the
number shipped so far; empty once every method has MIN_SEEDS, as now (the progress-aware
methods shipped each seed as it finished training)."""

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
"""Fixed observations [d_g, theta_g, v, w, l_1..l_8]."""

PROGRESS_ENTRIES = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],  # the first step: no previous action yet
        [0.05, 1 / 3, 2 / 3, 1 / 3, 0.8],
        [0.6, 1 / 3, 1 / 3, 1 / 3, 0.4],
        [1.0, 1.0, 1 / 3, 2 / 3, 1.0],  # stalled a whole window
        [0.3, 2 / 3, 1 / 3, 1.0, 0.6],
        [0.9, 1 / 3, 1.0, 1 / 3, 0.8],
    ]
)
"""[stalled, prev_wp, prev_wc, prev_ws, prev_tau] appended to OBSERVATIONS for the methods
that read the progress observation (docs/design.md#progress-observation)."""


def observations_for(method: str) -> np.ndarray:
    """OBSERVATIONS in the observation kind the method's policy reads, (6, 12) or (6, 17)."""
    if method_observation(method) == "progress":
        return np.hstack([OBSERVATIONS, PROGRESS_ENTRIES])
    return OBSERVATIONS


GOLDEN_ACTIONS = {
    "dqdwa": {
        0: [21, 9, 1, 18, 23, 24],
        1: [20, 2, 7, 4, 13, 19],
        2: [22, 10, 10, 18, 18, 5],
        3: [2, 16, 14, 0, 1, 4],
        4: [20, 18, 5, 24, 7, 6],
    },
    "d3dwa-weights": {
        0: [4, 9, 5, 23, 22, 23],
        1: [17, 20, 7, 17, 2, 19],
        2: [22, 22, 18, 19, 18, 1],
        3: [18, 8, 12, 16, 2, 11],
        4: [13, 6, 9, 19, 17, 16],
    },
    "d3dwa": {
        0: [52, 59, 72, 78, 13, 29],
        1: [19, 3, 14, 48, 57, 12],
        2: [44, 59, 10, 13, 59, 19],
        3: [34, 7, 80, 22, 43, 11],
        4: [71, 98, 24, 50, 61, 6],
    },
    "d3dwa-dr": {
        0: [49, 32, 8, 58, 13, 99],
        1: [19, 89, 40, 62, 42, 21],
        2: [84, 84, 84, 33, 37, 45],
        3: [42, 93, 40, 9, 42, 95],
        4: [67, 47, 0, 47, 17, 37],
    },
    "d3dwa-pa": {
        0: [35, 62, 13, 20, 36, 32],
        1: [62, 56, 24, 5, 49, 4],
        2: [49, 43, 65, 25, 43, 81],
        3: [35, 51, 44, 13, 0, 61],
        4: [8, 92, 23, 19, 62, 51],
    },
    "d3dwa-pa-dr": {
        0: [44, 35, 69, 1, 88, 76],
        1: [45, 69, 92, 69, 45, 10],
        2: [52, 6, 40, 42, 47, 5],
        3: [28, 80, 55, 59, 23, 93],
        4: [46, 46, 91, 97, 46, 90],
    },
}
"""Greedy action index of each shipped seed for each of OBSERVATIONS, recorded from the
weights in policies/. After shipping new seeds on purpose, regenerate them with
``python tests/learning/test_shipped_policies.py`` and paste its output here."""

SEEDS = [(m, k) for m in LEARNED for k in seed_dirs(default_policy_path(m))]


def greedy_actions(method: str, seed: int) -> list[int]:
    """The shipped seed's greedy action index for each of OBSERVATIONS."""
    path = seed_dirs(default_policy_path(method))[seed]
    policy, _, _ = load_policy(
        path,
        expected_actions=LEARNED[method],
        expected_observation=(method_observation(method), method),
    )
    return [int(policy(obs)) for obs in observations_for(method)]


@pytest.mark.parametrize("method", list(LEARNED))
def test_every_learned_method_ships_its_seeds_of_one_experiment(method: str) -> None:
    folder = default_policy_path(method)
    seeds = seed_dirs(folder)
    need = SHORT_OF_TARGET.get(method, MIN_SEEDS)
    assert len(seeds) >= need, f"{folder}: {len(seeds)} training seeds, need {need}"
    assert not (folder / "meta.json").exists()  # no single policy beside the seeds
    check_one_experiment(folder, seeds)  # one config (but the seed) and one action set
    budgets = {load_train_config(p / "config.json").total_steps for p in seeds.values()}
    assert len(budgets) == (1 if seeds else 0)


@pytest.mark.parametrize(("method", "seed"), SEEDS)
def test_shipped_seed_loads_with_its_action_set_and_travels_with_its_run(method, seed):
    path = seed_dirs(default_policy_path(method))[seed]
    policy, actions, meta = load_policy(
        path,
        expected_actions=LEARNED[method],
        expected_observation=(method_observation(method), method),
    )
    assert meta["method"] == method and actions.size == LEARNED[method].size
    assert meta["agent"] == ("dqdwa" if method == "dqdwa" else "d3qn")
    names = {p.name for p in path.iterdir()}
    assert {"meta.json", "config.json", "learning_curve.png", "summary.json"} <= names
    assert not names & {"replay.npz", "training_state.json", "training_state.pt"}
    config = load_train_config(path / "config.json")
    assert config.method == method and config.seed == seed
    summary = json.loads((path / "summary.json").read_text())
    assert summary["status"] == "done" and summary["env_steps"] >= config.total_steps
    assert set(json.loads((path / "meta.json").read_text())["files"]) <= names
    assert 0 <= policy(observations_for(method)[0]) < actions.size


@pytest.mark.parametrize(("method", "seed"), SEEDS)
def test_shipped_seed_chooses_the_recorded_actions(method: str, seed: int) -> None:
    assert {(m, k) for m in GOLDEN_ACTIONS for k in GOLDEN_ACTIONS[m]} == set(SEEDS)
    assert greedy_actions(method, seed) == GOLDEN_ACTIONS[method][seed]
    path = seed_dirs(default_policy_path(method))[seed]
    controller = make_controller(method, path)  # what evaluation runs: the same weights
    assert [controller(obs)[0] for obs in observations_for(method)] == GOLDEN_ACTIONS[method][seed]


if __name__ == "__main__":
    print("GOLDEN_ACTIONS = {")
    for name in LEARNED:
        seeds = seed_dirs(default_policy_path(name))
        print(f"    {name!r}: {{")
        for k in seeds:
            print(f"        {k}: {greedy_actions(name, k)},")
        print("    },")
    print("}")
