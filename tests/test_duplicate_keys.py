"""A key given twice is refused by the one loader, for every file the project reads: YAML
would keep the last value silently, so a field repeated at the end of a training config
trained on it with exit 0 (issue 42, class 1). One line names the file, the key and its line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import CheckpointError, ConfigError, ProfileError, WorldFormatError
from d3dwa_bullet.learning.training.config import load_train_config
from d3dwa_bullet.loading import load_json, parse_yaml
from d3dwa_bullet.resources import configs_dir, generators_dir, profiles_dir
from d3dwa_bullet.world.generator_spec import load_generator
from d3dwa_bullet.world.registry import load_world
from randomization.profiles import load_profile
from tests.conftest import ONE_SECOND_WORLD


def _appended(text: str, line: str, path: Path) -> Path:
    path.write_text(text.rstrip("\n") + "\n" + line + "\n")
    return path


def _one_line(err: pytest.ExceptionInfo, *names: object) -> None:
    message = str(err.value)
    assert "\n" not in message, message
    for name in names:
        assert str(name) in message, (name, message)


def test_a_training_config_repeating_a_field_is_refused(tmp_path):
    text = (configs_dir() / "d3dwa.yaml").read_text()
    count = len(text.rstrip("\n").splitlines()) + 1
    path = _appended(text, "decision_steps: 1", tmp_path / "twice.yaml")
    with pytest.raises(ConfigError) as err:
        load_train_config(path)
    _one_line(err, path, "'decision_steps'", f"line {count}", "twice")


def test_the_cli_says_it_in_one_line_with_status_2(tmp_path, capsys):
    text = (configs_dir() / "dqdwa.yaml").read_text()
    path = _appended(text, "total_steps: 3", tmp_path / "twice.yaml")
    assert main(["train", "--config", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'total_steps'" in err and str(path) in err, err
    assert not (tmp_path / "run").exists()


def test_a_world_file_repeating_a_key_is_refused(tmp_path):
    text = yaml.safe_dump(ONE_SECOND_WORLD)
    path = _appended(text, "time_limit: 900", tmp_path / "w.yaml")
    with pytest.raises(WorldFormatError) as err:
        load_world(path)
    _one_line(err, path, "'time_limit'", "twice")


def test_a_noise_profile_repeating_a_key_is_refused(tmp_path):
    text = (profiles_dir() / "real.yaml").read_text()
    path = _appended(text, "name: other", tmp_path / "p.yaml")
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    _one_line(err, path, "'name'", "twice")


def test_nested_repeats_and_json_objects_are_refused_too(tmp_path):
    with pytest.raises(ConfigError) as err:
        parse_yaml("agent:\n  lr: 0.1\n  gamma: 0.9\n  lr: 1.0\n", ConfigError, "c.yaml")
    _one_line(err, "c.yaml", "'lr'", "line 4", "first on line 2")
    meta = tmp_path / "meta.json"
    meta.write_text('{"metadata": {"decision_steps": 10, "decision_steps": 1}}')
    with pytest.raises(CheckpointError) as err:
        load_json(meta, CheckpointError)
    _one_line(err, meta, "'decision_steps'", "twice")


def test_merge_keys_and_distinct_keys_still_load():
    text = "base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  x: 3\n1: a\n'1': b\n"
    assert parse_yaml(text, ConfigError, "m.yaml") == {
        "base": {"x": 1, "y": 2},
        "other": {"x": 3, "y": 2},
        1: "a",
        "1": "b",
    }


FLOW = '{"method": "d3dwa", "total_steps": 30, "total_steps": 99999}'


@pytest.mark.parametrize(
    ("text", "key", "line", "first"),
    [
        ("a: 1\nb: 2\na: 3\n", "'a'", "line 3, column 1", "first on line 1, column 1"),
        (FLOW, "'total_steps'", "line 1, column 40", "first on line 1, column 21"),
        ("{a: 1,\n b: 2,\n a: 3}\n", "'a'", "line 3, column 2", "first on line 1, column 2"),
        ("agent: {lr: 0.1, gamma: 0.9, lr: 1.0}\n", "'lr'", "line 1", "first on line 1"),
        ("a:\n  - {x: 1, x: 2}\n", "'x'", "line 2", "first on line 2"),
        ("{1: a, 0x1: b}", "key 1 ", "line 1", "first on line 1"),  # one int, two spellings
    ],
)  # fmt: skip
def test_a_key_given_twice_is_refused_whatever_the_layout(text, key, line, first):
    """Keys are told apart by value within the mapping, not by line: on one line (flow style,
    JSON) the old loader kept the last value silently (issue 58, class 1)."""
    with pytest.raises(ConfigError) as err:
        parse_yaml(text, ConfigError, "c.yaml")
    _one_line(err, "c.yaml", key, line, first, "twice")


def test_a_flow_style_training_config_repeating_a_field_is_refused(tmp_path, capsys):
    data = yaml.safe_load((configs_dir() / "d3dwa.yaml").read_text())
    data["total_steps"] = 30
    text = json.dumps(data)  # JSON is flow-style YAML: every key on one line
    path = tmp_path / "flow.yaml"
    path.write_text(text[:-1] + ', "total_steps": 99999}')
    assert main(["train", "--config", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'total_steps'" in err and "line 1" in err, err
    assert not (tmp_path / "run").exists()


def test_merge_keys_over_merged_bases_still_load():
    """A base that itself merges another holds both bases' keys once flattened; only the keys
    a mapping writes itself are compared, so nothing here is a repeat, and the document loads
    as ``yaml.safe_load`` reads it."""
    text = (
        "q: &Q {a: 1, z: 0}\n"
        "p: &P {<<: *Q, a: 2}\n"
        "m: {<<: [*P, *Q], a: 3, b: 1}\n"
        "n:\n  <<: *P\n  z: 9\n"
    )
    loaded = parse_yaml(text, ConfigError, "m.yaml")
    assert loaded == yaml.safe_load(text)
    assert loaded["p"] == {"a": 2, "z": 0} and loaded["m"] == {"a": 3, "z": 0, "b": 1}


def _flow_with(data: dict, key: str, value: object, path: Path) -> Path:
    """``data`` as one line of JSON (flow-style YAML) with ``key`` given again at the end."""
    path.write_text(json.dumps(data)[:-1] + f", {json.dumps(key)}: {json.dumps(value)}}}\n")
    return path


@pytest.mark.parametrize(
    ("what", "load", "error", "key", "value"),
    [
        ("world", load_world, WorldFormatError, "time_limit", 900),
        ("profile", load_profile, ProfileError, "name", "other"),
        ("generator", load_generator, WorldFormatError, "style", "other"),
    ],
)  # fmt: skip
def test_every_user_yaml_refuses_a_key_repeated_on_one_line(
    tmp_path, what, load, error, key, value
):
    """Worlds, noise profiles and generator specs are read by the same loader as configs."""
    data = {
        "world": lambda: dict(ONE_SECOND_WORLD),
        "profile": lambda: yaml.safe_load((profiles_dir() / "real.yaml").read_text()),
        "generator": lambda: yaml.safe_load(next(generators_dir().glob("*.yaml")).read_text()),
    }[what]()
    path = _flow_with(data, key, value, tmp_path / f"{what}.yaml")
    with pytest.raises(error) as err:
        load(path)
    _one_line(err, path, repr(key), "line 1, column", "twice")


def test_a_json_file_names_the_line_of_the_repeated_key(tmp_path):
    meta = tmp_path / "meta.json"
    meta.write_text('{"metadata": {"decision_steps": 10,\n  "decision_steps": 1}}')
    with pytest.raises(CheckpointError) as err:
        load_json(meta, CheckpointError)
    _one_line(err, meta, "'decision_steps'", "line 2, column 3", "twice")
