"""Training configs' observation and stall-penalty fields: the paper's defaults, and bad values
refused by name. No registered method reads the progress-aware observation since its methods
left the registry (issue 41), so a config asking for it is refused."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.training import TrainConfig, load_train_config
from d3dwa_bullet.params import RewardParams
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT


def test_observation_defaults_to_the_methods_kind_and_reward_to_the_papers() -> None:
    base = {"worlds": ("TS1",), "generators": (), "eval_worlds": ("TS1",)}
    paper = TrainConfig.from_dict(base)
    assert paper.observation == "paper" and paper.obs_layout == OBSERVATION_LAYOUT
    assert paper.reward_params == RewardParams(scale=0.01)
    assert TrainConfig.from_dict(paper.to_dict()) == paper


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"method": "d3dwa", "observation": "stack3"}, r"\.observation: unknown .*'stack3'"),
        ({"method": "d3dwa", "observation": "progress"}, "reads the 'paper' observation"),
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
