"""The record of a policy's BARN training worlds (``learning.agents.barn_record``): written as
meta.json ``metadata.barn``, read back without torch, a malformed one refused in one line."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.barn_record import (
    BarnTraining,
    barn_record,
    barn_training,
    folder_barn_training,
)


def _folder(tmp_path, metadata):
    folder = tmp_path / "policy"
    folder.mkdir()
    (folder / "meta.json").write_text(json.dumps({"metadata": metadata}))
    return folder


def test_a_run_without_barn_records_nothing_and_one_with_it_its_split_and_ids():
    assert barn_record("none", ()) == {}
    assert barn_record("train", (1, 61)) == {"barn": {"split": "train", "ids": [1, 61]}}


def test_a_folder_reads_back_what_was_recorded(tmp_path):
    folder = _folder(tmp_path, {"decision_steps": 10, **barn_record("train", (61, 1))})
    record = folder_barn_training(folder)
    assert record == BarnTraining("train", (61, 1))
    assert record.names == {"BARN-1", "BARN-61"} and record.split_size == 250


def test_a_folder_without_a_record_or_without_meta_trained_on_no_barn_world(tmp_path):
    assert folder_barn_training(_folder(tmp_path, {"decision_steps": 10})) is None
    assert folder_barn_training(tmp_path / "nowhere") is None


def test_seeds_union_their_worlds():
    union = BarnTraining("train", (7, 1)).union(BarnTraining("train", (2, 1)))
    assert union == BarnTraining("train", (1, 2, 7))


@pytest.mark.parametrize(
    ("value", "names"),
    [
        ({"split": "challenge", "ids": [0]}, ("metadata.barn.split", "'challenge'")),
        ({"split": "all", "ids": [1]}, ("metadata.barn.split", "'all'")),
        ({"ids": [1]}, ("metadata.barn.split", "None")),
        ({"split": "train", "ids": [1, 6]}, ("metadata.barn.ids", "[1, 6]", "train worlds")),
        ({"split": "train", "ids": [1, 1]}, ("metadata.barn.ids", "distinct")),
        ({"split": "train", "ids": [300]}, ("metadata.barn.ids", "[300]")),
        ({"split": "train", "ids": ["1"]}, ("metadata.barn.ids", "['1']")),
        ({"split": "train", "ids": []}, ("metadata.barn.ids", "[]")),
        ([1, 2], ("metadata.barn.split",)),
    ],
)
def test_a_malformed_record_is_refused_in_one_line_naming_file_and_key(tmp_path, value, names):
    folder = _folder(tmp_path, {"barn": value})
    with pytest.raises(CheckpointError) as err:
        folder_barn_training(folder)
    text = str(err.value)
    assert "\n" not in text and text.startswith(str(folder / "meta.json"))
    assert all(n in text for n in names), text


def test_the_reader_takes_the_record_whatever_key_it_is_given():
    with pytest.raises(CheckpointError, match=r"^here\.split"):
        barn_training({"split": "challenge", "ids": [0]}, "here")
