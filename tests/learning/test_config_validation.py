"""A training config is checked whole when it loads, before any work (issue 42, class 2):
an unknown ``eval_noise`` or ``noise`` profile, a non-finite number (``lr: .inf``) and a
field out of range are one line naming the file and the field, exit 2 from ``train``."""

from __future__ import annotations

from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.training.config import TrainConfig, load_train_config
from d3dwa_bullet.limits import MAX_DECISION_STEPS
from tests.support.config_refusal import refused_at_load

BASE = "method: dqdwa\nworlds: [TS1]\ngenerators: []\nn_envs: 1\n"


def _config(tmp_path: Path, extra: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(BASE + extra)
    return path


@pytest.mark.parametrize(
    ("extra", "names"),
    [
        ("eval_noise: nonsuch\neval_every: 0\nkeep: final\n", ("eval_noise", "'nonsuch'")),
        ("eval_noise: nonsuch\n", ("eval_noise", "'nonsuch'")),
        ("noise: [none, nonsuch]\n", ("TrainConfig.noise", "'nonsuch'")),
        ("eval_noise: missing/p.yaml\n", ("eval_noise", "missing/p.yaml")),
        ("generator_prob: .nan\n", ("generator_prob", "finite")),
        ("stall_after: .inf\n", ("stall_after", "finite")),
        ("decision_steps: 101\n", ("decision_steps", f"[1, {MAX_DECISION_STEPS.value}]")),
        ("decision_steps: 2.5\n", ("decision_steps", "whole number")),
    ],
)
def test_a_bad_field_is_refused_at_load_naming_field_and_file(tmp_path, extra, names):
    refused_at_load(_config(tmp_path, extra), names)


def test_an_infinite_learning_rate_is_refused_at_load(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("method: d3dwa\nagent:\n  lr: .inf\n")
    with pytest.raises(ConfigError, match=r"agent\.lr' must be a finite number, got inf"):
        load_train_config(path)


def test_the_constructor_checks_profiles_too():
    with pytest.raises(ConfigError, match="TrainConfig.eval_noise: unknown profile 'nope'"):
        TrainConfig(method="dqdwa", eval_noise="nope")
    assert TrainConfig(method="dqdwa", eval_noise="harsh").eval_noise == "harsh"


def test_train_refuses_before_any_work_in_one_line(tmp_path, capsys):
    path = _config(tmp_path, "eval_noise: nonsuch\neval_every: 0\nkeep: final\n")
    out = tmp_path / "run"
    assert main(["train", "--config", str(path), "--out", str(out), "--total-steps", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "eval_noise" in err and str(path) in err, err
    assert not out.exists()
