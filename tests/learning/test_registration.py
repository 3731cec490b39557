"""The env id works from the package import alone: gymnasium.make and Stable-Baselines3."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from d3dwa_bullet import ENV_ID


def run_python(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    return out.stdout


def test_gymnasium_make_after_importing_only_the_package():
    """``import d3dwa_bullet`` registers the id by its entry-point string: the env module is
    imported by ``make``, not before, and the env it builds steps."""
    code = (
        "import sys, gymnasium, d3dwa_bullet\n"
        "print('loaded' if 'd3dwa_bullet.learning.env' in sys.modules else 'lazy')\n"
        f"env = gymnasium.make({ENV_ID!r})\n"
        "obs, info = env.reset(seed=0)\n"
        "obs, r, term, trunc, info = env.step(env.action_space.sample())\n"
        "print(type(env.unwrapped).__name__, obs.shape, obs.dtype, env.action_space.n,"
        " info['world'] in d3dwa_bullet.learning.env.TRAIN_WORLDS)\n"
        "env.close()\n"
    )
    lines = run_python(code).splitlines()
    assert lines == ["lazy", "D3DWAEnv (12,) float32 100 True"]


def test_gymnasium_make_with_the_module_prefix_imports_the_package():
    """gymnasium's ``module:id`` form: nothing imported by hand but gymnasium."""
    code = (
        "import gymnasium\n"
        f"env = gymnasium.make('d3dwa_bullet:{ENV_ID}')\n"
        "print(env.spec.id, env.observation_space.shape)\n"
        "env.close()\n"
    )
    assert run_python(code).split() == [ENV_ID, "(12,)"]


def test_stable_baselines3_dqn_trains_on_the_env_id():
    """SB3 builds the env from the id string (``gym.make`` inside) and trains a few hundred
    steps: its Monitor, replay buffer and Q-network accept the spaces."""
    sb3 = pytest.importorskip("stable_baselines3")
    model = sb3.DQN(
        "MlpPolicy",
        ENV_ID,
        buffer_size=1_000,
        learning_starts=100,
        train_freq=4,
        target_update_interval=100,
        policy_kwargs={"net_arch": [32]},
        seed=0,
        device="cpu",
    )
    assert model.observation_space.shape == (12,) and model.action_space.n == 100
    model.learn(total_timesteps=300)
    assert model.num_timesteps == 300
    assert model._n_updates == (300 - 100) // 4
    action, _ = model.predict(np.zeros(12, dtype=np.float32), deterministic=True)
    assert 0 <= int(action) < 100
    model.get_env().close()
