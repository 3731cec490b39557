"""Which BARN worlds a policy trained on: the one home of that record, written and read.

A run with ``barn_split`` set (docs/design/training.md#barn-training) records in its checkpoint's
meta.json ``metadata.barn = {"split": "train", "ids": [...]}`` (world numbers, in the order
they were trained on); ``trainer`` writes it through :func:`barn_record`, and an evaluation
reads it back through :func:`folder_barn_training` to say on its pages which worlds the policy
trained on and to flag the rows evaluated on them (``evaluation.training_worlds``). A policy
without the record (the shipped ones, any run before BARN) trained on no BARN world.

Pure: JSON only, no torch (an evaluation reads it before any episode runs).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.policy_terms import read_meta, shown_value
from d3dwa_bullet.world.barn import BARN_WORLDS, SPLIT_GROUPS, barn_name, barn_split, barn_split_ids

BARN_KEY = "barn"
"""The key of the record in a checkpoint's ``metadata``."""
TRAINABLE = tuple(s for s in SPLIT_GROUPS if s != "challenge")
"""Splits a run may train on: ``train`` (``challenge`` is refused at load, ``all`` holds it)."""


@dataclass(frozen=True)
class BarnTraining:
    """The BARN worlds a policy trained on: ``split`` (``train``) and ``ids``, world numbers."""

    split: str
    ids: tuple[int, ...]

    @property
    def names(self) -> frozenset[str]:
        """The world names, ``BARN-<i>``."""
        return frozenset(barn_name(i) for i in self.ids)

    @property
    def split_size(self) -> int:
        """Worlds in the whole split (250 for ``train``)."""
        return len(barn_split_ids(self.split))

    def to_dict(self) -> dict[str, Any]:
        """``{"split": ..., "ids": [...]}``, as meta.json records it."""
        return {"split": self.split, "ids": list(self.ids)}

    def union(self, other: BarnTraining) -> BarnTraining:
        """Both records' worlds (ids ascending); CheckpointError for two splits."""
        if other.split != self.split:
            raise CheckpointError(
                f"training seeds record BARN splits {self.split!r} and {other.split!r}"
            )
        return BarnTraining(self.split, tuple(sorted(set(self.ids) | set(other.ids))))


def barn_record(split: str, ids: tuple[int, ...]) -> dict[str, Any]:
    """The ``metadata`` entry of a run on BARN's ``split`` worlds ``ids``: ``{"barn": {...}}``,
    or {} for ``split`` 'none' (the meta of runs without BARN is unchanged)."""
    if split == "none":
        return {}
    return {BARN_KEY: BarnTraining(split, tuple(ids)).to_dict()}


def barn_training(value: object, where: str) -> BarnTraining:
    """A recorded ``{"split", "ids"}`` mapping as a BarnTraining. CheckpointError (one line,
    ``where`` first: the file and key) unless the split is trainable and the ids are distinct
    whole numbers of that split's worlds."""
    split = value.get("split") if isinstance(value, Mapping) else None
    ids = value.get("ids") if isinstance(value, Mapping) else None
    if split not in TRAINABLE:
        raise CheckpointError(
            f"{where}.split is {shown_value(split)}, expected one of {', '.join(TRAINABLE)} "
            "(the BARN split the policy trained on)"
        )
    ok = isinstance(ids, list) and all(type(i) is int for i in ids) and len(set(ids)) == len(ids)
    if not ok or not ids or any(not 0 <= i < BARN_WORLDS or barn_split(i) != split for i in ids):
        raise CheckpointError(
            f"{where}.ids is {shown_value(ids)}, expected distinct numbers of BARN's {split} worlds "
            "(the worlds the policy trained on)"
        )
    return BarnTraining(str(split), tuple(ids))


def checkpoint_barn_training(meta: Mapping[str, Any], where: str) -> BarnTraining | None:
    """The record of a checkpoint's meta.json ``meta`` (None without one); where: the file."""
    extra = meta.get("metadata", {})
    if not isinstance(extra, Mapping) or BARN_KEY not in extra:
        return None  # a bad metadata block is policy_terms.checkpoint_terms's to refuse
    return barn_training(extra[BARN_KEY], f"{where}: metadata.{BARN_KEY}")


def folder_barn_training(folder: str | os.PathLike[str]) -> BarnTraining | None:
    """The record in a policy folder's meta.json; None when it has none or no meta.json (a
    bare Q-table, whose loader says what it lacks)."""
    meta_file = Path(folder) / "meta.json"
    if not meta_file.is_file():
        return None
    return checkpoint_barn_training(read_meta(meta_file), str(meta_file))
