"""Every learned method ships five or more training seeds in policies/<method>/seed-<k>/, each
loading with its method's action set, carrying its config, learning curve and run summary,
all trained under one config, and choosing the recorded greedy actions (so swapped,
retrained or altered weights are caught)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from d3dwa_bullet.controllers import default_policy_path, make_controller
from d3dwa_bullet.evaluation.policy_runs import check_one_experiment
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.method_specs import LEARNED, method_observation
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.planning.observation_kinds import make_observer
from d3dwa_bullet.resources import configs_dir
from d3dwa_bullet.seed_dirs import seed_dirs

MIN_SEEDS = 5
"""The learning protocol's minimum (docs/design/learning-protocol.md#learning-protocol)."""

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


def observations_for(method: str) -> np.ndarray:
    """OBSERVATIONS in the observation kind the method's policy reads, each as the first step
    of an episode would see it: (6, 12) for the paper's, (6, 124) for the history kind."""
    rows = []
    for obs in OBSERVATIONS:
        observer = make_observer(method_observation(method))
        rows.append(obs if observer is None else observer.extend(obs, 0, (0.0, 0.0, 0.0)))
    return np.array(rows)


GOLDEN_ACTIONS = {
    "dqdwa": {
        0: [9, 0, 17, 14, 12, 20],
        1: [24, 5, 8, 20, 12, 16],
        2: [0, 5, 5, 18, 20, 9],
        3: [0, 2, 18, 22, 3, 19],
        4: [6, 0, 21, 6, 2, 0],
    },
    "d3dwa-weights": {
        0: [19, 11, 20, 1, 13, 11],
        1: [17, 11, 21, 10, 3, 3],
        2: [19, 10, 23, 20, 15, 22],
        3: [19, 19, 15, 12, 6, 13],
        4: [19, 19, 4, 19, 21, 10],
    },
    "d3dwa": {
        0: [85, 99, 3, 25, 44, 45],
        1: [68, 18, 4, 96, 83, 56],
        2: [76, 66, 86, 21, 2, 7],
        3: [96, 7, 70, 90, 18, 9],
        4: [40, 47, 73, 45, 71, 61],
    },
    "d3dwa-dr": {
        0: [32, 32, 20, 82, 71, 54],
        1: [71, 50, 68, 40, 44, 57],
        2: [94, 94, 98, 94, 31, 67],
        3: [38, 19, 18, 23, 72, 65],
        4: [64, 39, 4, 38, 92, 85],
    },
    "d3dwa-history-dr": {
        0: [93, 8, 13, 35, 24, 75],
        1: [22, 22, 30, 74, 84, 17],
        2: [55, 93, 38, 51, 72, 12],
        3: [41, 69, 6, 68, 78, 13],
        4: [70, 73, 67, 43, 36, 11],
    },
    "d3dwa-weights-barn": {
        0: [20, 21, 8, 21, 1, 1],
        1: [14, 12, 18, 21, 14, 21],
        2: [16, 17, 7, 0, 2, 9],
        3: [18, 11, 18, 20, 2, 20],
        4: [21, 18, 3, 7, 6, 11],
    },
    "d3dwa-barn": {
        0: [93, 26, 15, 72, 43, 40],
        1: [85, 97, 19, 80, 80, 25],
        2: [27, 16, 35, 30, 82, 96],
        3: [49, 63, 74, 87, 55, 46],
        4: [11, 30, 56, 90, 13, 22],
    },
    "d3dwa-dr-barn": {
        0: [45, 24, 75, 40, 40, 28],
        1: [36, 36, 55, 60, 25, 28],
        2: [5, 6, 75, 85, 36, 81],
        3: [84, 82, 30, 45, 28, 9],
        4: [35, 39, 97, 94, 36, 83],
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


def decide(controller: Controller, obs: np.ndarray) -> int:
    """The action a controller decides on ``obs`` at an episode's first step (a controller
    holds each decision for its policy's decision period, so each observation starts anew)."""
    controller.reset(0)
    return controller(obs)[0]


@pytest.mark.parametrize("method", list(LEARNED))
def test_every_learned_method_ships_its_seeds_of_one_experiment_or_is_training(
    method: str,
) -> None:
    folder = default_policy_path(method)
    if not folder.exists():
        # a method whose seeds are training (a new one beside the paper's) ships nothing yet,
        # and has the config its seeds train under
        assert method != "d3dwa" and (configs_dir() / f"{method}.yaml").is_file(), method
        return
    seeds = seed_dirs(folder)
    assert len(seeds) >= MIN_SEEDS, f"{folder}: {len(seeds)} training seeds, need {MIN_SEEDS}"
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
    # trained under the committed config, seed aside: no seed of another learner ships
    committed, mine = (
        load_train_config(configs_dir() / f"{method}.yaml").to_dict(),
        config.to_dict(),
    )
    for fields in (committed, mine, committed["agent"], mine["agent"]):
        fields.pop("seed", None)
    assert mine == committed
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
    assert [decide(controller, obs) for obs in observations_for(method)] == GOLDEN_ACTIONS[method][
        seed
    ]


if __name__ == "__main__":
    print("GOLDEN_ACTIONS = {")
    for name in LEARNED:
        seeds = seed_dirs(default_policy_path(name))
        print(f"    {name!r}: {{")
        for k in seeds:
            print(f"        {k}: {greedy_actions(name, k)},")
        print("    },")
    print("}")
