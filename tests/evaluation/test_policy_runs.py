"""Which policies an evaluation drives: every training seed of a method's folder by default,
a chosen few with --policy-seeds, and folders whose seeds are not one experiment refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.errors import CheckpointError, ConfigError, ResultsError
from d3dwa_bullet.evaluation.jobs import Job, evaluate
from d3dwa_bullet.evaluation.policy_runs import PolicyRun, method_runs, policy_digests
from d3dwa_bullet.evaluation.same_run import check_same_run
from d3dwa_bullet.learning.agents.checkpoint import save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.world.registry import load_world

CONFIG = {"method": "d3dwa", "total_steps": 1000, "seed": 0, "agent": {"lr": 0.0003, "seed": 0}}


def seed_folder(root: Path, seeds=(0, 1, 2), actions=ACTIONS_FULL, lr=None) -> Path:
    """root/d3dwa/seed-<k>/ for each seed: an untrained D3QN and its config.json."""
    for k in seeds:
        agent = D3QNAgent(actions, D3QNConfig(hidden=(8,), seed=k))
        path = save_checkpoint(root / "d3dwa" / f"seed-{k}", agent, method="d3dwa")
        config = json.loads(json.dumps(CONFIG))
        config["seed"] = config["agent"]["seed"] = k
        if lr is not None and k == seeds[-1]:
            config["agent"]["lr"] = lr
        (path / "config.json").write_text(json.dumps(config))
    return root / "d3dwa"


def test_every_seed_by_default_and_a_few_on_request(tmp_path):
    folder = seed_folder(tmp_path)
    runs = method_runs(["d3dwa"], str(folder))
    assert [(r.method, r.policy_seed) for r in runs] == [("d3dwa", 0), ("d3dwa", 1), ("d3dwa", 2)]
    assert runs[1].policy == str(folder / "seed-1")
    assert [r.policy_seed for r in method_runs(["d3dwa"], str(folder), "2,0")] == [2, 0]
    assert [r.policy_seed for r in method_runs(["d3dwa"], str(folder), "all")] == [0, 1, 2]


def test_fixed_methods_single_policies_and_one_seed_folder(tmp_path):
    folder = seed_folder(tmp_path)
    assert method_runs(["dwa3"]) == [PolicyRun("dwa3")]
    one = save_checkpoint(tmp_path / "one", D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(8,))))
    assert method_runs(["d3dwa"], str(one)) == [PolicyRun("d3dwa", None, str(one))]
    seed = str(folder / "seed-2")
    assert method_runs(["d3dwa"], seed) == [PolicyRun("d3dwa", 2, seed)]


def test_a_seed_that_is_not_shipped_is_named(tmp_path):
    folder = seed_folder(tmp_path)
    with pytest.raises(ConfigError, match=rf"--policy-seeds: {folder} has no seed-7 \(it has "
                       r"seed-0, seed-1, seed-2\)"):  # fmt: skip
        method_runs(["d3dwa"], str(folder), "0,7")
    with pytest.raises(ConfigError, match="--policy-seeds: 'x' in 'x'"):
        method_runs(["d3dwa"], str(folder), "x")
    with pytest.raises(ConfigError, match="no learned method here has seed-<k> folders"):
        method_runs(["dwa1", "dwa3"], None, "0")


def test_seeds_of_another_config_or_action_set_are_refused(tmp_path):
    folder = seed_folder(tmp_path / "lr", lr=0.001)
    with pytest.raises(CheckpointError, match=r"d3dwa: seed-2 was trained under another config "
                       r"or action set than seed-0 \(config.agent.lr 0.0003 vs 0.001\)"):  # fmt: skip
        method_runs(["d3dwa"], str(folder))
    assert len(method_runs(["d3dwa"], str(folder), "0,1")) == 2  # the two that agree
    mixed = seed_folder(tmp_path / "actions", seeds=(0,))
    seed_folder(tmp_path / "actions", seeds=(1,), actions=ACTIONS_WEIGHTS_ONLY)
    with pytest.raises(CheckpointError, match=r"seed-1 was trained under another config or "
                       r"action set than seed-0 \(actions"):  # fmt: skip
        method_runs(["d3dwa"], str(mixed))


def test_digests_name_each_seeds_weights(tmp_path):
    folder = seed_folder(tmp_path)
    runs = method_runs(["dwa3", "d3dwa"], str(folder))
    digests = policy_digests(runs)
    assert list(digests) == ["d3dwa/seed-0", "d3dwa/seed-1", "d3dwa/seed-2"]
    meta = json.loads((folder / "seed-1" / "meta.json").read_text())
    assert digests["d3dwa/seed-1"] == meta["files"]["weights.pt"]["sha256"]
    assert len(set(digests.values())) == 3  # three seeds, three different networks


def test_a_resumed_evaluation_refuses_rows_driven_by_other_weights(one_second_world, tmp_path):
    """Retraining a method replaces its seed folders' weights; rows its old weights drove
    must not be mixed with the new ones under the same key."""
    jobs = [Job(load_world(one_second_world), "dwa1", 0, "none")]
    evaluate(jobs, tmp_path, progress=False, settings={"policy_digests": {"d3dwa/seed-0": "a"}})
    keys = [j.key for j in jobs]
    same = {"policy_digests": {"d3dwa/seed-0": "a", "d3dwa/seed-1": "b"}}  # extended: fine
    check_same_run(tmp_path, keys, EpisodeConfig(), same)
    with pytest.raises(ResultsError, match=r"its d3dwa/seed-0 episodes were driven by other"):
        check_same_run(tmp_path, keys, EpisodeConfig(), {"policy_digests": {"d3dwa/seed-0": "c"}})
