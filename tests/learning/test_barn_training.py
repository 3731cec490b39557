"""Training on BARN's train split (issue 56, part 1): the ``barn_split`` / ``barn_worlds`` fields
add BARN worlds to the training material in a fixed order, are refused at load in one line
naming the field and the file (exit 2 from ``train``), and the policy's meta records the ids."""

from __future__ import annotations

from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.learning.training import TrainConfig, load_train_config, make_env
from d3dwa_bullet.method_specs import LEARNED, barn_twin
from d3dwa_bullet.resources import configs_dir
from d3dwa_bullet.world.barn import barn_name, barn_split_ids
from tests.support.config_refusal import refused_at_load
from tests.support.tiny_policy import tiny_run

BASE = "method: d3dwa\ngenerators: []\nn_envs: 1\n"


def _config_file(tmp_path: Path, extra: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(BASE + extra)
    return path


def test_barn_is_off_by_default_and_adds_nothing():
    config = TrainConfig()
    assert config.barn_split == "none" and config.barn_ids == ()
    assert config.training_worlds == config.worlds


def test_all_of_train_and_never_a_challenge_world():
    ids = TrainConfig(barn_split="train").barn_ids
    assert ids == barn_split_ids("train") and len(ids) == 250
    assert not set(ids) & set(barn_split_ids("challenge"))


@pytest.mark.parametrize("count", [1, 5, 50, 249, 250])
def test_a_count_takes_that_many_evenly_spread_distinct_train_worlds(count):
    ids = TrainConfig(barn_split="train", barn_worlds=count).barn_ids
    members = barn_split_ids("train")
    assert len(ids) == len(set(ids)) == count and set(ids) <= set(members)
    assert list(ids) == sorted(ids) and ids[0] == members[0]


def test_the_diversity_curve_counts_are_nested_and_independent_of_the_seed():
    five, fifty, all_ = (
        set(TrainConfig(barn_split="train", barn_worlds=k, seed=s).barn_ids)
        for k, s in ((5, 3), (50, 7), (250, 11))
    )
    assert five < fifty < all_
    assert (
        TrainConfig(barn_split="train", barn_worlds=50, seed=1).barn_ids
        == TrainConfig(barn_split="train", barn_worlds=50, seed=2).barn_ids
    )


def test_barn_worlds_mix_with_worlds_and_generators_in_the_env(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("method: d3dwa\nworlds: [TS1]\nbarn_split: train\nbarn_worlds: 5\nn_envs: 1\n")
    config = load_train_config(path)
    ids = config.barn_ids
    assert config.training_worlds == ("TS1", *(f"BARN-{i}" for i in ids))
    env = make_env(config)
    try:
        assert env.tasks[: 1 + len(ids)] == config.training_worlds
        assert env.tasks[1 + len(ids) :] == config.generators
    finally:
        env.close()


def test_barn_alone_is_training_material(tmp_path):
    config = load_train_config(
        _config_file(tmp_path, "worlds: []\nbarn_split: train\nbarn_worlds: 2\n")
    )
    assert config.training_worlds == tuple(f"BARN-{i}" for i in config.barn_ids)


@pytest.mark.parametrize(
    ("extra", "names"),
    [
        ("barn_split: challenge\n", ("barn_split", "'challenge'", "evaluation only")),
        ("barn_split: all\n", ("barn_split", "'all'")),
        ("barn_split: nonsuch\n", ("barn_split", "'nonsuch'")),
        ("barn_split: train\nbarn_worlds: 251\n", ("barn_worlds", "251", "[1, 250]")),
        ("barn_split: train\nbarn_worlds: 0\n", ("barn_worlds", "0")),
        ("barn_split: train\nbarn_worlds: -5\n", ("barn_worlds", "-5")),
        ("barn_split: train\nbarn_worlds: 2.5\n", ("barn_worlds", "whole number")),
        ("barn_split: train\neval_worlds: [BARN-1, BARN-6]\n", ("eval_worlds", "BARN-6")),
        ("barn_split: train\neval_worlds: [BARN-0]\n", ("eval_worlds", "barn-challenge")),
        ("worlds: [BARN-12]\n", ("worlds", "BARN-12", "barn-challenge")),
        ("barn_worlds: 5\n", ("barn_worlds", "5", "barn_split is 'none'")),
    ],
)
def test_a_bad_barn_field_is_refused_at_load_naming_field_and_file(tmp_path, extra, names):
    refused_at_load(_config_file(tmp_path, extra), names)


def test_a_barn_named_method_off_barn_is_refused_at_load(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(BASE.replace("method: d3dwa", "method: d3dwa-barn"))
    refused_at_load(path, ("barn_split", "'d3dwa-barn'", "must be 'train'"))


def test_validation_on_train_split_worlds_is_allowed(tmp_path):
    path = _config_file(tmp_path, "barn_split: train\nbarn_worlds: 5\neval_worlds: [BARN-1]\n")
    assert load_train_config(path).eval_worlds == ("BARN-1",)


@pytest.mark.parametrize(
    "extra", ["barn_split: challenge\n", "barn_split: train\nbarn_worlds: 300\n"]
)
def test_train_refuses_a_bad_barn_field_with_exit_2_before_any_work(tmp_path, capsys, extra):
    path = _config_file(tmp_path, extra)
    out = tmp_path / "run"
    assert main(["train", "--config", str(path), "--out", str(out), "--total-steps", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "barn_" in err and str(path) in err, err
    assert not out.exists()


@pytest.mark.parametrize(("count", "why"), [("0", "got 0"), ("251", "got 251")])
def test_train_refuses_a_diversity_count_beyond_the_split_in_one_line(tmp_path, capsys, count, why):
    path = _config_file(tmp_path, "barn_split: train\n")
    out = tmp_path / "run"
    assert main(["train", "--config", str(path), "--out", str(out), "--barn-worlds", count]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--barn-worlds" in err and "[1, 250]" in err and why in err
    assert not out.exists()


def test_the_barn_worlds_flag_sets_the_count_of_the_config(tmp_path):
    path = _config_file(tmp_path, "barn_split: train\n")
    assert (
        load_train_config(path, barn_worlds=5).barn_ids
        == TrainConfig(barn_split="train", barn_worlds=5).barn_ids
    )


@pytest.mark.parametrize("name", ["d3dwa-barn", "d3dwa-weights-barn", "d3dwa-dr-barn"])
def test_the_barn_configs_change_only_the_training_material_of_their_twin(name):
    twin = barn_twin(name)
    assert twin is not None and LEARNED[name] == LEARNED[twin]
    mine, theirs = (load_train_config(configs_dir() / f"{m}.yaml") for m in (name, twin))
    assert mine.barn_ids == barn_split_ids("train") and mine.worlds == mine.generators == ()
    assert not {barn_name(i) for i in barn_split_ids("challenge")} & set(mine.eval_worlds)
    material = {"method", "worlds", "generators", "generator_prob", "barn_split", "eval_worlds"}
    differs = {k for k, v in mine.to_dict().items() if theirs.to_dict()[k] != v}
    assert differs <= material and {"method", "barn_split"} <= differs, differs


def _tiny_barn_run(tmp_path: Path, **changes) -> dict:
    _, meta = load_checkpoint(tiny_run(tmp_path / "run", **changes))
    return meta["metadata"]


def test_the_policy_meta_records_its_barn_training_worlds(tmp_path):
    metadata = _tiny_barn_run(tmp_path, barn_split="train", barn_worlds=3)
    ids = TrainConfig(barn_split="train", barn_worlds=3).barn_ids
    assert metadata["barn"] == {"split": "train", "ids": list(ids)}


def test_a_run_without_barn_records_none(tmp_path):
    metadata = _tiny_barn_run(tmp_path, generators=("R1-style",))
    assert "barn" not in metadata
