"""tools.bench.bench_train counts control steps, also for a config that decides every k of them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.learning.test_training import TINY_WORLD, _config
from tools.bench import bench_train


@pytest.mark.parametrize("decision_steps", [1, 10])
def test_figures_are_in_control_steps(tmp_path: Path, decision_steps: int) -> None:
    world = tmp_path / "tiny.yaml"
    world.write_text(TINY_WORLD)
    config = _config(str(world), decision_steps=decision_steps)
    path = tmp_path / "config.json"  # JSON is YAML: load_train_config reads it
    path.write_text(json.dumps(config.to_dict()))
    result = bench_train.run(steps=200, config=path)
    assert result["decision_steps"] == decision_steps
    assert result["env_steps"] == 200  # 200 control steps, however many decisions
    loop = result["loop_steps_per_s"]
    assert result["minutes_per_250k_steps"] == pytest.approx(250_000 / loop / 60, abs=0.01)
    assert loop == pytest.approx(200 / result["wall_time_s"], rel=0.5)  # not 10x off


def test_a_tabular_config_is_refused_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    from d3dwa_bullet.resources import configs_dir

    assert bench_train.main(["--config", str(configs_dir() / "dqdwa.yaml"), "--steps", "10"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("bench_train: error: ") and "dqdwa.yaml" in err
    assert "'dqdwa' is not a D3QN learner" in err and "\n" not in err
