"""SB3's DQN cross-check: a tiny budget on the shipped config's env, figures consistent."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.learning.value_calibration import calibrate, discounted_returns
from d3dwa_bullet.resources import configs_dir
from tools.experiments.sb3_crosscheck import DEFAULT_CONFIG, main

pytest.importorskip("stable_baselines3")


def tiny_config(tmp_path: Path) -> Path:
    """The shipped config with a tiny net, replay and warm-up, and one evaluation world."""
    data = yaml.safe_load((configs_dir() / DEFAULT_CONFIG).read_text())
    data["agent"].update(hidden=[16], buffer_size=1000, learning_starts=100)
    data["eval_worlds"] = ["R1-style-s1"]
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_tiny_run_gives_finite_consistent_figures(tmp_path, capsys) -> None:
    config = tiny_config(tmp_path)
    assert main(["--config", str(config), "--steps", "300", "--seed", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (episode,) = out["episodes"]
    gamma, agent = out["gamma"], load_train_config(config).agent
    assert gamma == out["hyperparameters"]["gamma"] == agent.gamma
    assert out["hyperparameters"]["n_steps"] == agent.n_step  # type: ignore[union-attr]
    # SB3 updates its target once per gradient step, one every train_freq env steps
    assert out["hyperparameters"]["target_update_interval"] == agent.train_freq  # type: ignore[union-attr]
    assert out["gradient_steps"] == (300 - 100) // agent.train_freq  # type: ignore[union-attr]
    rewards, q = np.array(episode["rewards"]), np.array(episode["q_taken"])
    assert len(rewards) == len(q) == episode["steps"] > 0
    assert np.isfinite(rewards).all() and np.isfinite(q).all()
    v = out["values"]
    assert v["pairs"] == episode["steps"] and v["episodes"] == 1
    assert v["mean_return"] == pytest.approx(discounted_returns(rewards, gamma).mean(), rel=1e-12)
    assert v["mean_q"] == pytest.approx(q.mean(), rel=1e-12)
    assert v == calibrate([q], [rewards], gamma).to_dict()
    assert out["mean_return"] == pytest.approx(rewards.sum(), rel=1e-12)
    assert out["success_rate"] == float(episode["outcome"] == "goal")
    assert all(math.isfinite(out[k]) for k in ("success_rate", "collision_rate", "mean_return"))


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--steps", "-5"], "--steps must be >= 1, got -5"),
        (["--seed", "-1"], "--seed must be >= 0, got -1"),
        (["--steps", "many"], "argument --steps: invalid int value: 'many'"),
        (["--eval-worlds", " , "], "--eval-worlds: give at least one world"),
        (["--hidden", "a,b"], "--hidden: not a list of whole numbers"),
        (["--config", "/nonexistent/x.yaml"], "/nonexistent/x.yaml"),
    ],
)
def test_bad_input_is_one_line_and_status_2(argv, named, capsys) -> None:
    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("sb3_crosscheck: error: ") and named in err
