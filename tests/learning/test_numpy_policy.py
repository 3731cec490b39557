"""The torch-free copy of a D3QN policy (weights.npz, ``numpy_policy``): in sync with every
shipped weights.pt, the same actions, refused when stale, and a shipped policy runs without
importing torch (docs/design/episode-cost.md)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest
import torch

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import NUMPY_WEIGHTS_FILE, WEIGHTS_FILE, read_meta
from d3dwa_bullet.learning.agents.numpy_policy import (
    load_numpy_policy,
    read_numpy_weights,
    write_beside_weights,
    write_numpy_weights,
)
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.resources import policies_dir
from tools.policy_npz import shipped_checkpoints

D3QN_SEEDS = [d for d in shipped_checkpoints() if read_meta(d)["agent"] == "d3qn"]


def test_every_shipped_d3qn_seed_has_its_weights_in_numpy():
    assert len(D3QN_SEEDS) >= 30
    for directory in D3QN_SEEDS:
        arrays, source = read_numpy_weights(directory / NUMPY_WEIGHTS_FILE)
        assert source == read_meta(directory)["files"][WEIGHTS_FILE]["sha256"], directory
        tensors = torch.load(directory / WEIGHTS_FILE, map_location="cpu", weights_only=True)
        assert sorted(arrays) == sorted(tensors), directory
        for name, tensor in tensors.items():
            assert arrays[name].dtype == np.float32
            assert np.array_equal(arrays[name], tensor.numpy()), (directory, name)


@pytest.mark.parametrize("method", ["d3dwa", "d3dwa-weights-barn", "d3dwa-history-dr"])
def test_numpy_policy_chooses_as_the_torch_loaded_one(method):
    directory = policies_dir() / method / "seed-1"
    kind = read_meta(directory)["metadata"]["observation"]
    fed = (kind, f"method {method!r}")
    fast, actions, _ = load_numpy_policy(directory, expected_observation=fed)
    slow, slow_actions, _ = load_policy(directory, expected_observation=fed)
    assert actions == slow_actions
    obs = np.random.default_rng(0).normal(size=(500, fast.obs_dim)) * 2.0
    assert [fast(o) for o in obs] == [slow(o) for o in obs]


def test_a_stale_copy_is_refused(tmp_path):
    directory = tmp_path / "seed-0"
    shutil.copytree(policies_dir() / "d3dwa" / "seed-0", directory)
    arrays, _ = read_numpy_weights(directory / NUMPY_WEIGHTS_FILE)
    write_numpy_weights(directory, arrays, "0" * 64)
    with pytest.raises(CheckpointError, match="another SHA-256"):
        load_numpy_policy(directory)


def test_a_wrong_array_is_refused(tmp_path):
    directory = tmp_path / "seed-0"
    shutil.copytree(policies_dir() / "d3dwa" / "seed-0", directory)
    arrays, source = read_numpy_weights(directory / NUMPY_WEIGHTS_FILE)
    arrays["advantage.bias"] = arrays["advantage.bias"][:-1]
    write_numpy_weights(directory, arrays, source)
    with pytest.raises(CheckpointError, match="'advantage.bias'"):
        load_numpy_policy(directory)


def test_without_a_copy_the_caller_loads_with_torch(tmp_path):
    directory = tmp_path / "seed-0"
    shutil.copytree(policies_dir() / "d3dwa" / "seed-0", directory)
    (directory / NUMPY_WEIGHTS_FILE).unlink()
    assert load_numpy_policy(directory) is None


def test_running_a_shipped_policy_imports_no_torch():
    code = (
        "import sys\n"
        "from d3dwa_bullet.cli.app import main\n"
        "code = main(['run', '--world', 'R1', '--method', 'd3dwa', '--time-limit', '0.2', '--json'])\n"
        "assert code == 0, code\n"
        "print(sys.modules.get('torch') is not None)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "False"


def test_a_copy_written_beside_a_checkpoint_runs_it(tmp_path):
    directory = tmp_path / "seed-2"
    shutil.copytree(policies_dir() / "d3dwa-dr" / "seed-2", directory)
    (directory / NUMPY_WEIGHTS_FILE).unlink()
    tensors = torch.load(directory / WEIGHTS_FILE, map_location="cpu", weights_only=True)
    write_beside_weights(directory, {k: v.numpy() for k, v in tensors.items()})
    fast, _, _ = load_numpy_policy(directory)
    slow, _, _ = load_policy(directory)
    obs = np.random.default_rng(2).normal(size=(200, fast.obs_dim))
    assert [fast(o) for o in obs] == [slow(o) for o in obs]
    (directory / WEIGHTS_FILE).write_bytes(b"not the weights")
    with pytest.raises(CheckpointError, match="truncated or altered"):
        write_beside_weights(directory, {k: v.numpy() for k, v in tensors.items()})
