"""``init_policy``: a run that starts from a trained policy's network (warm_start)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path

import pytest
import torch

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.training import TrainConfig, train
from d3dwa_bullet.learning.training.seeds import train_seeds
from d3dwa_bullet.learning.training.warm_start import source
from tests.learning.test_training import SMALL_AGENT, TINY_WORLD, _config, _weights


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """A tiny world and a folder of two trained seeds (0 and 1) of it."""
    root = tmp_path_factory.mktemp("warm")
    world = root / "tiny.yaml"
    world.write_text(TINY_WORLD)
    train_seeds(_config(str(world), total_steps=60), root / "runs", [0, 1],
                export=root / "policies", progress=False)  # fmt: skip
    return str(world), root / "policies"


def test_each_seed_starts_from_its_own_seed_and_records_it(
    seeds: tuple[str, Path], tmp_path: Path
) -> None:
    world, policies = seeds
    # no gradient step in 30 decisions (learning_starts 1000): the final network is the start
    frozen = replace(SMALL_AGENT, learning_starts=1000)
    config = _config(world, total_steps=30, agent=frozen, init_policy=str(policies), seed=1)
    train(config, tmp_path / "run", progress=False)
    got, want = _weights(tmp_path / "run" / "policy"), _weights(policies / "seed-1")
    assert all(torch.equal(got[k], want[k]) for k in want)
    other = _weights(policies / "seed-0")
    assert any(not torch.equal(got[k], other[k]) for k in other)
    run = json.loads((tmp_path / "run" / "run.json").read_text())
    digest = hashlib.sha256((policies / "seed-1" / "weights.pt").read_bytes()).hexdigest()
    assert run["init_policy"] == {"folder": str(policies / "seed-1"), "weights_sha256": digest}


def test_a_warm_started_run_learns_and_repeats_itself(
    seeds: tuple[str, Path], tmp_path: Path
) -> None:
    world, policies = seeds
    config = _config(world, total_steps=60, init_policy=str(policies / "seed-0"), seed=3)
    train(config, tmp_path / "a", progress=False)
    train(config, tmp_path / "b", progress=False)
    a, b = _weights(tmp_path / "a" / "policy"), _weights(tmp_path / "b" / "policy")
    assert all(torch.equal(a[k], b[k]) for k in a)  # same seed, same run
    start = _weights(policies / "seed-0")
    assert any(not torch.equal(a[k], start[k]) for k in a)  # and it trained from there


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"init_policy": "no/such/folder"}, "neither a policy folder"),
        ({"init_policy": "SEEDS", "seed": 4}, "seed-4"),
        ({"init_policy": "SEEDS", "agent": replace(SMALL_AGENT, hidden=(8, 8))}, "hidden"),
        ({"init_policy": "SEEDS", "decision_steps": 5}, "decision_steps 1"),
        ({"init_policy": "SEEDS", "recovery": "nav2"}, "recovery 'none'"),
        (
            {"init_policy": "SEEDS", "scan_filter": "median"},
            "scan_filter 'none', this run has 'median'",
        ),
        ({"init_policy": "SEEDS", "method": "d3dwa-weights"}, "action set"),
    ],
)
def test_a_start_that_does_not_fit_is_refused_naming_the_field(
    seeds: tuple[str, Path], changes: dict, message: str
) -> None:
    world, policies = seeds
    if changes.get("init_policy") == "SEEDS":
        changes = changes | {"init_policy": str(policies)}
    config = _config(world, **changes)
    with pytest.raises(ConfigError, match="TrainConfig.init_policy") as err:
        source(config)
    assert message in str(err.value)


def test_a_missing_seed_is_refused_before_any_seed_trains(
    seeds: tuple[str, Path], tmp_path: Path
) -> None:
    world, policies = seeds
    config = _config(world, total_steps=30, init_policy=str(policies))
    with pytest.raises(ConfigError, match="seed-2"):
        train_seeds(config, tmp_path / "runs", [0, 2], progress=False)
    assert not (tmp_path / "runs" / "seed-0" / "config.json").exists()


def test_a_shipped_method_name_means_its_shipped_seeds() -> None:
    config = TrainConfig(method="d3dwa", decision_steps=10, recovery="nav2",
                         init_policy="d3dwa", seed=2, n_envs=1)  # fmt: skip
    start = source(config)
    assert start is not None and start.folder.name == "seed-2"
    assert start.folder.parent.name == "d3dwa"


@pytest.mark.parametrize("value", ["3", "''", "[a]"])
def test_cli_refuses_a_bad_init_policy_in_one_line(
    seeds: tuple[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    world, _ = seeds
    path = tmp_path / "bad.yaml"
    path.write_text(f"method: d3dwa\nworlds: [{world}]\ngenerators: []\ninit_policy: {value}\n")
    assert main(["train", "--config", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "init_policy" in err and str(path) in err
    assert not (tmp_path / "run").exists()
