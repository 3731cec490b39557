"""seed_ensemble writes a checkpoint whose Q-values are the mean of its members'."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.resources import policies_dir
from tools.experiments.seed_ensemble import mean_network, write_ensembles


def test_the_wide_network_is_the_members_mean() -> None:
    torch.manual_seed(3)
    members = [DuelingQNetwork(12, 100, (16, 8)) for _ in range(3)]
    wide = mean_network(members)
    x = torch.randn(64, 12)
    with torch.no_grad():
        expected = sum(m(x) for m in members) / 3
        assert torch.allclose(wide(x), expected, atol=1e-5)
        assert not torch.allclose(members[0](x), expected, atol=1e-3)
    assert wide.hidden == (48, 24)


def test_leave_one_out_ensembles_drive_like_the_mean_of_the_other_seeds(tmp_path: Path) -> None:
    folder = policies_dir() / "d3dwa-dr"
    written = write_ensembles(folder, tmp_path / "ens")
    assert sorted(written) == [0, 1, 2, 3, 4]
    agent, meta = load_checkpoint(written[2])
    assert sorted(meta["metadata"]["ensemble_of"]) == ["seed-0", "seed-1", "seed-3", "seed-4"]
    members = [load_checkpoint(folder / f"seed-{k}")[0] for k in (0, 1, 3, 4)]
    networks = [m.online for m in members if isinstance(m, D3QNAgent)]
    assert len(networks) == 4
    torch.manual_seed(0)
    obs = torch.rand(200, 12) * torch.tensor([5, 6.3, 0.3, 1.0] + [3.0] * 8) - torch.tensor(
        [0, 3.1, 0, 0.5] + [0.0] * 8
    )
    with torch.no_grad():
        mean_q = torch.stack([n(obs) for n in networks]).mean(dim=0)
    policy = load_policy(written[2])[0]
    greedy = [policy(o.numpy()) for o in obs]
    assert greedy == mean_q.argmax(dim=1).tolist()


def test_a_folder_of_one_seed_is_refused(tmp_path: Path) -> None:
    (tmp_path / "one").mkdir()
    with pytest.raises(CheckpointError, match="needs 3 or more seed folders"):
        write_ensembles(tmp_path / "one", tmp_path / "out")


def test_the_ensemble_records_only_what_its_members_share(tmp_path: Path) -> None:
    written = write_ensembles(policies_dir() / "d3dwa-dr", tmp_path / "ens", leave_one_out=False)
    metadata = load_checkpoint(written[0])[1]["metadata"]
    assert metadata["decision_steps"] == 10 and metadata["recovery"] == "nav2"
    assert "eval" not in metadata and "run" not in metadata  # one member's, not the ensemble's
    assert len(metadata["ensemble_of"]) == 5


def test_a_tabular_policy_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError, match="dqdwa: not a D3QN policy"):
        write_ensembles(policies_dir() / "dqdwa", tmp_path / "out")
    assert not (tmp_path / "out").exists()
