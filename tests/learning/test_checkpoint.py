"""Checkpoints: round trips, every rejected mismatch, and atomic replacement."""

from __future__ import annotations

import errno
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import CheckpointError, WriteError
from d3dwa_bullet.learning.agents import checkpoint as ckpt
from d3dwa_bullet.learning.agents import checkpoint_files, checkpoint_load, checkpoint_save
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint, save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.network import DuelingQNetwork, parameter_count
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT

SMALL = D3QNConfig(hidden=(16, 16), batch_size=8, buffer_size=64, learning_starts=8, seed=2)


def _observations(n: int = 64, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    obs = rng.random((n, 12))
    obs[:, 1:4] = 2.0 * obs[:, 1:4] - 1.0
    return obs


def _trained_d3qn(actions=ACTIONS_FULL, seed: int = 2) -> D3QNAgent:
    agent = D3QNAgent(actions, replace(SMALL, seed=seed))
    obs = _observations(20, seed)
    for i in range(19):
        agent.learn(Transition(obs[i], i % actions.size, 0.01 * i, obs[i + 1], i == 18))
    assert agent.train_steps > 0
    return agent


def _dqdwa() -> DQDWAAgent:
    agent = DQDWAAgent(config=DQDWAConfig(seed=1))
    agent.table[...] = np.random.default_rng(5).normal(size=agent.table.shape)
    agent.train_steps = agent.env_steps = 123
    return agent


def _edit_meta(directory: Path, **changes) -> None:
    path = directory / "meta.json"
    meta = json.loads(path.read_text())
    for key, value in changes.items():
        meta[key] = value
    path.write_text(json.dumps(meta))


def _refresh_digest(directory: Path, name: str) -> None:
    """Make meta.json agree with a tampered data file, to reach the deeper checks."""
    path = directory / "meta.json"
    meta = json.loads(path.read_text())
    meta["files"][name] = checkpoint_files.digest(directory / name)
    path.write_text(json.dumps(meta))


@pytest.mark.parametrize(
    ("actions", "method"), [(ACTIONS_FULL, "d3dwa"), (ACTIONS_WEIGHTS_ONLY, "d3dwa-weights")]
)
def test_d3qn_round_trip(tmp_path: Path, actions, method: str) -> None:
    agent = _trained_d3qn(actions)
    out = save_checkpoint(tmp_path / "ck", agent, {"world": "TS1", "seed": 2})
    assert sorted(p.name for p in out.iterdir()) == ["meta.json", "weights.pt"]
    loaded, meta = load_checkpoint(out)
    assert isinstance(loaded, D3QNAgent)
    obs = _observations()
    assert np.array_equal(loaded.q_values(obs), agent.q_values(obs))
    for k, v in loaded.target.state_dict().items():
        assert torch.equal(v, agent.online.state_dict()[k])
    assert loaded.config == agent.config and loaded.actions == actions
    assert (loaded.train_steps, loaded.env_steps) == (agent.train_steps, agent.env_steps)
    assert loaded.epsilon() == agent.epsilon()
    assert meta["method"] == method and meta["agent"] == "d3qn"
    assert meta["observation"] == {"layout": list(OBSERVATION_LAYOUT), "dim": 12}
    assert meta["package_version"] == __version__ and meta["format_version"] == ckpt.FORMAT_VERSION
    assert meta["metadata"] == {"world": "TS1", "seed": 2}

    policy, policy_actions, _ = load_policy(out)
    assert policy_actions == actions
    assert [policy(o) for o in obs] == [agent.act(o, greedy=True) for o in obs]


def test_dqdwa_round_trip(tmp_path: Path) -> None:
    agent = _dqdwa()
    out = save_checkpoint(tmp_path / "tab", agent)
    assert sorted(p.name for p in out.iterdir()) == ["meta.json", "table.npy"]
    loaded, meta = load_checkpoint(out)
    assert isinstance(loaded, DQDWAAgent)
    assert np.array_equal(loaded.table, agent.table)
    assert loaded.config == agent.config and loaded.train_steps == 123
    assert meta["method"] == "dqdwa" and meta["actions"]["size"] == 25
    policy, actions, _ = load_policy(out)
    assert actions == ACTIONS_WEIGHTS_ONLY
    obs = _observations()
    assert [policy(o) for o in obs] == [agent.act(o, greedy=True) for o in obs]


def test_explicit_method_name(tmp_path: Path) -> None:
    _, meta = load_checkpoint(save_checkpoint(tmp_path / "a", _trained_d3qn(), method="d3dwa-real"))
    assert meta["method"] == "d3dwa-real"


@pytest.fixture
def saved(tmp_path: Path) -> Path:
    return save_checkpoint(tmp_path / "ck", _trained_d3qn())


def test_expected_action_set_mismatch(saved: Path) -> None:
    with pytest.raises(CheckpointError, match="meta.json: action set .* differs"):
        load_checkpoint(saved, expected_actions=ACTIONS_WEIGHTS_ONLY)
    with pytest.raises(CheckpointError, match="action set"):
        load_policy(saved, expected_actions=ACTIONS_WEIGHTS_ONLY)


def test_action_set_not_matching_weights(saved: Path) -> None:
    _edit_meta(saved, actions=ACTIONS_WEIGHTS_ONLY.to_dict())
    with pytest.raises(
        CheckpointError, match=r"weights.pt: tensor 'advantage.weight' has shape \(100, 16\)"
    ):
        load_checkpoint(saved)


def test_hidden_size_not_matching_weights(saved: Path) -> None:
    meta = json.loads((saved / "meta.json").read_text())
    _edit_meta(saved, config={**meta["config"], "hidden": [32, 16]})
    with pytest.raises(CheckpointError, match="body.0.weight"):
        load_checkpoint(saved)


def test_a_network_larger_than_its_weights_file_is_refused_before_allocation(
    saved: Path, monkeypatch
) -> None:
    meta = json.loads((saved / "meta.json").read_text())
    _edit_meta(saved, config={**meta["config"], "hidden": [100_000, 100_000]})

    def no_network(*args, **kwargs):
        raise AssertionError("the network was built")

    monkeypatch.setattr(checkpoint_load, "D3QNAgent", no_network)
    with pytest.raises(CheckpointError, match=r"10,011,500,101 weights .* holds only"):
        load_checkpoint(saved)


@pytest.mark.parametrize(("obs_dim", "n_actions", "hidden"), [(12, 100, (128, 128)), (17, 5, (3,))])
def test_parameter_count_is_the_built_networks(obs_dim, n_actions, hidden) -> None:
    network = DuelingQNetwork(obs_dim, n_actions, hidden)
    assert parameter_count(obs_dim, n_actions, hidden) == sum(
        p.numel() for p in network.parameters()
    )


@pytest.mark.parametrize(
    ("observation", "match"),
    [
        (
            {"layout": list(OBSERVATION_LAYOUT) + ["extra"], "dim": 13},
            r"observation layout .* \(dim 13\) differs",
        ),
        ({"layout": list(OBSERVATION_LAYOUT), "dim": 13}, "dim 13 disagrees"),
        ({"layout": list(reversed(OBSERVATION_LAYOUT)), "dim": 12}, "observation layout"),
    ],
)
def test_observation_mismatch(saved: Path, observation: dict, match: str) -> None:
    _edit_meta(saved, observation=observation)
    with pytest.raises(CheckpointError, match=match):
        load_checkpoint(saved)


@pytest.mark.parametrize("version", [0, 2, "1", None])
def test_wrong_format_version(saved: Path, version) -> None:
    _edit_meta(saved, format_version=version)
    with pytest.raises(CheckpointError, match="meta.json: format_version is"):
        load_checkpoint(saved)


def test_truncated_weights(saved: Path) -> None:
    data = (saved / "weights.pt").read_bytes()
    (saved / "weights.pt").write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="weights.pt: truncated"):
        load_checkpoint(saved)
    _refresh_digest(saved, "weights.pt")  # even if meta.json agreed: too small for the network
    with pytest.raises(CheckpointError, match="weights.pt holds only"):
        load_checkpoint(saved)
    (saved / "weights.pt").write_bytes(bytes(len(data)))  # large enough, but not a torch file
    _refresh_digest(saved, "weights.pt")
    with pytest.raises(CheckpointError, match="weights.pt: cannot be read"):
        load_checkpoint(saved)


def test_corrupt_weights_same_size(saved: Path) -> None:
    data = bytearray((saved / "weights.pt").read_bytes())
    data[len(data) // 2] ^= 0xFF
    (saved / "weights.pt").write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="weights.pt: corrupt"):
        load_checkpoint(saved)


def test_non_finite_weights(saved: Path) -> None:
    state = torch.load(saved / "weights.pt", weights_only=True)
    state["value.bias"][0] = float("nan")
    torch.save(state, saved / "weights.pt")
    _refresh_digest(saved, "weights.pt")
    with pytest.raises(CheckpointError, match="'value.bias' holds NaN"):
        load_checkpoint(saved)


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (None, "meta.json: missing"),
        ("{not json", "not valid JSON"),
        ("[1, 2]", "JSON object"),
        ('{"format_version": 1}', "missing field"),
    ],
)
def test_bad_meta(saved: Path, content: str | None, match: str) -> None:
    if content is None:
        (saved / "meta.json").unlink()
    else:
        (saved / "meta.json").write_text(content)
    with pytest.raises(CheckpointError, match=match):
        load_checkpoint(saved)


def test_missing_data_file(saved: Path) -> None:
    (saved / "weights.pt").unlink()
    with pytest.raises(CheckpointError, match="weights.pt: missing"):
        load_checkpoint(saved)


def test_table_shape_mismatch(tmp_path: Path) -> None:
    out = save_checkpoint(tmp_path / "tab", _dqdwa())
    np.save(out / "table.npy", np.zeros((135, 100)))
    _refresh_digest(out, "table.npy")
    with pytest.raises(CheckpointError, match=r"table.npy: Q-table has shape \(135, 100\)"):
        load_checkpoint(out)


def test_truncated_table(tmp_path: Path) -> None:
    out = save_checkpoint(tmp_path / "tab", _dqdwa())
    data = (out / "table.npy").read_bytes()
    (out / "table.npy").write_bytes(data[:100])
    with pytest.raises(CheckpointError, match="table.npy: truncated"):
        load_checkpoint(out)
    _refresh_digest(out, "table.npy")
    with pytest.raises(CheckpointError, match="table.npy: cannot be read"):
        load_checkpoint(out)


def _assert_intact(directory: Path, reference: D3QNAgent) -> None:
    loaded, _ = load_checkpoint(directory)
    obs = _observations()
    assert np.array_equal(loaded.q_values(obs), reference.q_values(obs))
    assert not [p for p in directory.parent.iterdir() if p.name.startswith(".")], (
        "temp dirs left behind"
    )


def test_failed_save_keeps_existing_checkpoint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    good = _trained_d3qn(seed=2)
    target = save_checkpoint(tmp_path / "ck", good)
    other = _trained_d3qn(seed=3)

    with pytest.raises(CheckpointError, match="not JSON-serialisable"):
        save_checkpoint(target, other, {"bad": object()})
    _assert_intact(target, good)

    def exploding_save(obj, f, *args, **kwargs):
        f.write(b"PK\x03\x04partial")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(checkpoint_save.torch, "save", exploding_save)
    with pytest.raises(
        WriteError, match=f"^{re.escape(str(target))}: cannot write: No space left on device$"
    ):
        save_checkpoint(target, other)
    _assert_intact(target, good)


def test_failed_swap_restores_old_checkpoint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    good = _trained_d3qn(seed=2)
    target = save_checkpoint(tmp_path / "ck", good)
    real_replace = checkpoint_save.os.replace

    def failing_replace(src, dst):
        if ".tmp-" in str(src):
            raise OSError("rename failed")
        return real_replace(src, dst)

    monkeypatch.setattr(checkpoint_save.os, "replace", failing_replace)
    with pytest.raises(OSError, match="rename failed"):
        save_checkpoint(target, _trained_d3qn(seed=3))
    monkeypatch.undo()
    _assert_intact(target, good)


def test_overwrite_with_new_checkpoint(tmp_path: Path) -> None:
    target = save_checkpoint(tmp_path / "ck", _trained_d3qn(seed=2))
    newer = _trained_d3qn(seed=3)
    save_checkpoint(target, newer)
    _assert_intact(target, newer)


def test_refuses_to_clobber_foreign_directory(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "notes.txt").write_text("keep me")
    with pytest.raises(CheckpointError, match="notes.txt"):
        save_checkpoint(run, _dqdwa())
    assert (run / "notes.txt").read_text() == "keep me"
