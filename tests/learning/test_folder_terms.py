"""One reader of a policy's terms (decision period, recovery layer, observation) that checks
meta.json against config.json and across the seeds of one policy folder (issue 42, class 3):
a malformed meta.json, or a seed whose meta disagrees, is refused in one line instead of
being driven every step."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.evaluation.policy_runs import method_runs
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from tests.support.held_policy import held_checkpoint


def _edit(path: Path, **changes: object) -> None:
    data = json.loads(path.read_text())
    data.update(changes)
    path.write_text(json.dumps(data))


def _config(folder: Path, **terms: object) -> None:
    (folder / "config.json").write_text(json.dumps({"method": "d3dwa", "seed": 0, **terms}))


def _one_line(err: pytest.ExceptionInfo, *names: object) -> None:
    message = str(err.value)
    assert "\n" not in message, message
    for name in names:
        assert str(name) in message, (name, message)


@pytest.mark.parametrize("bad", [["decision_steps", 10], "10", 10, None])
def test_a_malformed_metadata_block_is_refused_not_read_as_the_papers(tmp_path, bad):
    folder = held_checkpoint(tmp_path / "p", decision_steps=10, recovery="none")
    _edit(folder / "meta.json", metadata=bad)
    with pytest.raises(CheckpointError) as err:
        make_controller("d3dwa", policy_path=folder)
    _one_line(err, folder / "meta.json", "metadata", "expected a mapping")


def test_meta_and_config_disagreeing_in_one_seed_is_refused(tmp_path):
    folder = held_checkpoint(tmp_path / "p", decision_steps=10, recovery="none")
    _config(folder, decision_steps=1, recovery="none", observation="paper")
    with pytest.raises(CheckpointError) as err:
        load_policy(folder)
    _one_line(err, "metadata.decision_steps is 10", folder / "config.json", "says 1")


def test_agreeing_files_give_the_terms(tmp_path):
    folder = held_checkpoint(tmp_path / "p", decision_steps=10, recovery="nav2")
    _config(folder, decision_steps=10, recovery="nav2", observation="paper")
    assert folder_terms(folder) == {
        "decision_steps": 10,
        "recovery": "nav2",
        "observation": "paper",
        "scan_filter": "none",
    }
    assert make_controller("d3dwa", policy_path=folder).hold == 10


def test_a_seed_whose_meta_disagrees_with_the_others_is_refused(tmp_path):
    root = tmp_path / "policy"
    held_checkpoint(root / "seed-0", decision_steps=10, recovery="none")
    held_checkpoint(root / "seed-1", decision_steps=10, recovery="none", seed=2)
    held_checkpoint(root / "seed-2", decision_steps=1, recovery="none", seed=3)
    assert len(method_runs(["d3dwa"], str(root), "0,1")) == 2
    with pytest.raises(CheckpointError) as err:
        method_runs(["d3dwa"], str(root))
    _one_line(err, "seed-2", "seed-0", "terms", "one experiment")


def test_eval_refuses_the_mixed_folder_in_one_line_with_status_2(tmp_path, capsys):
    root = tmp_path / "policy"
    held_checkpoint(root / "seed-0", decision_steps=10, recovery="none")
    held_checkpoint(root / "seed-1", decision_steps=3, recovery="none", seed=2)
    out = tmp_path / "r"
    argv = ["eval", "--methods", "d3dwa", "--policy", str(root), "--worlds", "TS1",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "seed-1" in err, err
