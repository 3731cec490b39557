"""The observation kinds on the command line: a policy of the other observation kind and an
unknown kind in a training config are refused in one line (exit 2). No registered method reads
the progress-aware observation since its methods left the registry (issue 41); a policy that
reads it is still told apart from the paper's."""

from __future__ import annotations

from pathlib import Path

import pytest

from d3dwa_bullet.cli import options
from d3dwa_bullet.cli.app import main
from d3dwa_bullet.cli.options import default_methods
from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
from d3dwa_bullet.method_specs import LEARNED, REFERENCE
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.observation_kinds import observation_layout


def run(capsys: pytest.CaptureFixture, *argv: object) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("d3dwa: error: "), err
    return lines[0]


@pytest.fixture(scope="module")
def pa_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An untrained D3QN reading the progress observation: its choices vary with it."""
    agent = D3QNAgent(
        ACTIONS_FULL, D3QNConfig(hidden=(32, 32), seed=3), observation_layout("progress")
    )
    return save_checkpoint(tmp_path_factory.mktemp("pa") / "pa", agent, method="d3dwa")


def test_a_progress_policy_is_refused_for_d3dwa(pa_policy, capsys):
    code, err = run(capsys, "run", "--method", "d3dwa", "--policy", pa_policy, "--world", "TS1")
    line = error_line(err)
    assert code == 2 and "reads the 'progress' observation (17 entries)" in line
    assert "method 'd3dwa' feeds the 'paper' observation (12 entries)" in line


def test_an_unknown_observation_kind_in_a_training_config(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text("method: d3dwa\nobservation: memory\ntotal_steps: 100\n")
    code, err = run(capsys, "train", "--config", config, "--out", tmp_path / "run")
    line = error_line(err)
    assert code == 2 and str(config) in line and "TrainConfig.observation" in line
    assert "'memory'" in line and "paper, progress, history" in line
    assert not (tmp_path / "run").exists()
    config.write_text("method: d3dwa\nobservation: progress\n")
    code, err = run(capsys, "train", "--config", config, "--out", tmp_path / "run")
    assert code == 2 and "method 'd3dwa' reads the 'paper' observation" in error_line(err)


def test_the_main_jobs_default_methods_are_the_papers_with_a_shipped_policy() -> None:
    methods = default_methods()
    assert methods[:3] == ["dwa1", "dwa2", "dwa3"] and set(REFERENCE) <= set(methods)
    for method in LEARNED:  # those trained on BARN are named, never a default
        shipped = default_policy_path(method).exists() and not method.endswith("-barn")
        assert (method in methods) == shipped


def test_a_barn_trained_policy_is_not_a_default_method(tmp_path, monkeypatch) -> None:
    def every_policy_exists(method: str, root: object = None) -> Path:
        return tmp_path  # exists

    monkeypatch.setattr(options, "default_policy_path", every_policy_exists)
    methods = options.default_methods()
    assert "d3dwa" in methods and "d3dwa-dr" in methods
    assert not [m for m in methods if m.endswith("-barn")]
