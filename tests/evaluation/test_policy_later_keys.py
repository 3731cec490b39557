"""Seeds trained before and after a training-config key was added are one experiment when the later
ones kept its default (evaluation/policy_runs.LATER_CONFIG_KEYS; issue 79's new seeds beside the shipped)."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.evaluation.policy_runs import LATER_CONFIG_KEYS, check_one_experiment
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.seed_dirs import seed_dirs

SHIPPED = Path(__file__).resolve().parents[2] / "policies" / "d3dwa-weights" / "seed-0"


def test_the_later_keys_hold_the_training_configs_defaults() -> None:
    defaults = {f.name: f.default for f in dataclasses.fields(TrainConfig)}
    assert LATER_CONFIG_KEYS == {k: defaults[k] for k in LATER_CONFIG_KEYS}


def _seed(root: Path, k: int, **changes: object) -> None:
    dest = root / f"seed-{k}"
    shutil.copytree(SHIPPED, dest)
    config = json.loads((dest / "config.json").read_text())
    config |= {"seed": k, **changes}
    (dest / "config.json").write_text(json.dumps(config))


def test_a_later_seed_with_the_defaults_joins_an_older_one(tmp_path: Path) -> None:
    old = json.loads((SHIPPED / "config.json").read_text())
    assert not set(LATER_CONFIG_KEYS) & set(old)  # the shipped seed predates them
    _seed(tmp_path, 0)
    _seed(tmp_path, 5, **LATER_CONFIG_KEYS)
    check_one_experiment(tmp_path, seed_dirs(tmp_path))  # no error
    _seed(tmp_path, 6, scan_filter="median")
    with pytest.raises(CheckpointError, match="scan_filter"):
        check_one_experiment(tmp_path, seed_dirs(tmp_path))
