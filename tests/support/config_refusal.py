"""A training config refused at load: one line that names its file (the tests then check the
field and value it names)."""

from __future__ import annotations

from pathlib import Path

import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.training.config import load_train_config


def refused_at_load(path: Path, names: tuple[str, ...]) -> None:
    """Assert that loading the config at path raises ConfigError in one line naming path and
    every one of names."""
    with pytest.raises(ConfigError) as err:
        load_train_config(path)
    message = str(err.value)
    assert "\n" not in message and str(path) in message, message
    for name in names:
        assert name in message, (name, message)
