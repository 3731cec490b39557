"""The learning package: its lazy re-exports, and a reward module free of torch and pybullet."""

from __future__ import annotations

import subprocess
import sys

import pytest

import d3dwa_bullet.learning as learning
from d3dwa_bullet.learning import env, tasks, training


def test_reward_imports_neither_torch_nor_pybullet() -> None:
    code = (
        "import sys, d3dwa_bullet.learning.reward; "
        "print('torch' in sys.modules, 'pybullet' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_reexports_are_the_defining_modules_objects() -> None:
    assert set(learning.__all__) <= set(dir(learning))
    assert learning.D3DWAEnv is env.D3DWAEnv
    assert learning.TaskSampler is tasks.TaskSampler
    assert learning.train is training.train and learning.TrainConfig is training.TrainConfig
    assert learning.export_policy is training.export_policy
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        learning.nope  # noqa: B018
