"""configs/ holds one training config per learned method; every pilot's config lives beside its
pilot's results in docs/pilots/<name>/config.yaml (issue 43), and still loads."""

from __future__ import annotations

from pathlib import Path

import pytest

from d3dwa_bullet.learning.training.config import load_train_config
from d3dwa_bullet.method_specs import LEARNED
from d3dwa_bullet.resources import configs_dir

PILOTS = Path(__file__).resolve().parents[1] / "docs" / "pilots"


def test_configs_holds_one_config_per_learned_method() -> None:
    assert sorted(p.stem for p in configs_dir().glob("*.yaml")) == sorted(LEARNED)
    assert [p.name for p in configs_dir().iterdir() if p.is_dir() and p.name != "__pycache__"] == []


@pytest.mark.parametrize(
    "config", sorted(PILOTS.glob("*/config.yaml")), ids=lambda p: p.parent.name
)
def test_every_pilot_config_lives_beside_its_pilot_and_loads(config: Path) -> None:
    loaded = load_train_config(config)
    assert loaded.method in LEARNED
    assert config.parent.name.startswith(loaded.method.removesuffix("-dr"))


def test_the_pilots_are_found() -> None:
    assert len(list(PILOTS.glob("*/config.yaml"))) >= 8
