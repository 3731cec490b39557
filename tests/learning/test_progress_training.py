"""Training the progress-aware methods: config fields, the committed configs, a tiny run."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.learning.training import TrainConfig, load_train_config, train
from d3dwa_bullet.methods import make_controller
from d3dwa_bullet.params import RewardParams
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.planning.progress import observation_layout
from tests.learning.test_training import SMALL_AGENT, TINY_WORLD

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
"""The committed configs of this checkout (what ``d3dwa train --config configs/...`` reads)."""
CHANGED = {"method", "observation", "stall_penalty", "stall_after"}
"""The only fields in which a progress-aware config may differ from its paper sibling."""


@pytest.fixture
def tiny(tmp_path: Path) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY_WORLD)
    return str(path)


def test_observation_defaults_to_the_methods_kind_and_reward_to_the_papers() -> None:
    base = {"worlds": ("TS1",), "generators": (), "eval_worlds": ("TS1",)}
    paper = TrainConfig.from_dict(base)
    assert paper.observation == "paper" and paper.obs_layout == OBSERVATION_LAYOUT
    assert paper.reward_params == RewardParams(scale=0.01)
    pa = TrainConfig.from_dict(base | {"method": "d3dwa-pa"})
    assert pa.observation == "progress" and pa.obs_layout == observation_layout("progress")
    assert TrainConfig.from_dict(pa.to_dict()) == pa


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"method": "d3dwa-pa", "observation": "stack3"}, r"\.observation: unknown .*'stack3'"),
        ({"method": "d3dwa-pa", "observation": "paper"}, "reads the 'progress' observation"),
        ({"method": "dqdwa", "observation": "progress"}, "reads the 'paper' observation"),
        ({"stall_penalty": 0.5}, r"TrainConfig\.stall_penalty must be a number <= 0, got 0.5"),
        ({"stall_after": -1.0}, r"TrainConfig\.stall_after must be"),
        ({"stall_penalty": "big"}, "field 'stall_penalty' must be a finite number"),
    ],
)
def test_bad_observation_and_stall_fields_are_refused(tmp_path: Path, changes, match) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({"worlds": ["TS1"], "generators": []} | changes))
    with pytest.raises(ConfigError, match=match) as err:
        load_train_config(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("method", "sibling"), [("d3dwa-pa", "d3dwa"), ("d3dwa-pa-dr", "d3dwa-dr")]
)
def test_committed_progress_configs_change_only_what_they_must(method: str, sibling: str) -> None:
    config = load_train_config(CONFIGS / f"{method}.yaml")
    paper = load_train_config(CONFIGS / f"{sibling}.yaml")
    a, b = config.to_dict(), paper.to_dict()
    assert CHANGED - {"stall_after"} <= {k for k in a if a[k] != b[k]} <= CHANGED
    assert config.method == method and config.observation == "progress"
    assert config.reward_params == RewardParams(scale=0.01, stall_penalty=-0.02, stall_after=5.0)
    assert (
        config.keep == paper.keep == "final"
    )  # fixed before training: docs/design.md#progress-checkpoint


def test_a_tiny_d3dwa_pa_run_trains_saves_and_loads_its_17_entry_policy(tiny, tmp_path) -> None:
    config = TrainConfig(
        method="d3dwa-pa", total_steps=150, worlds=(tiny,), generators=(), agent=SMALL_AGENT,
        eval_every=75, eval_worlds=(tiny,), checkpoint_every=0, log_every=50, keep="final",
        n_envs=1, stall_penalty=-0.02, stall_after=0.5,
    )  # fmt: skip
    out = tmp_path / "run"
    part = train(replace(config, total_steps=90), out, progress=False)
    assert part["status"] == "done" and part["env_steps"] == 90
    summary = train(config, out, resume=True, progress=False)  # the latest checkpoint reloads
    assert summary["status"] == "done" and summary["env_steps"] == 150
    assert load_train_config(out / "config.json") == config
    agent, meta = load_checkpoint(out / "policy", expected_layout=observation_layout("progress"))
    assert meta["observation"]["dim"] == 17 and meta["metadata"]["observation"] == "progress"
    controller = make_controller("d3dwa-pa", out / "policy")
    assert controller.observation == "progress"
    index, action = controller(np.full(17, 0.5))
    assert 0 <= index < 100 and action.tau in (2.0, 3.0, 4.0, 5.0)
    with pytest.raises(CheckpointError, match="method 'd3dwa' feeds the 'paper' observation"):
        make_controller("d3dwa", out / "policy")
