"""A checkpoint's ``meta.json`` read and checked, torch-free: its version and fields, every data
file's size and SHA-256, and the observation layout and action set the policy is driven with.

``checkpoint_load`` builds the agent on these checks; ``numpy_policy`` runs a shipped D3QN policy
from them without importing torch (docs/design/episode-cost.md)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.checkpoint_files import (
    DATA_FILES,
    FORMAT_VERSION,
    META_FILE,
    digest,
)
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import kind_of_layout


def read_meta(directory: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse and version-check ``meta.json`` of a checkpoint; CheckpointError on any problem."""
    path = Path(directory) / META_FILE
    if not path.is_file():
        raise CheckpointError(f"{path}: missing (not a checkpoint directory?)")
    meta = load_json(path, CheckpointError, "checkpoint meta.json")
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path}: expected a JSON object, got {type(meta).__name__}")
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise CheckpointError(
            f"{path}: format_version is {version!r}, this code reads version {FORMAT_VERSION}"
        )
    required = ("agent", "method", "observation", "actions", "config", "training_steps", "files")
    missing = [k for k in required if k not in meta]
    if missing:
        raise CheckpointError(f"{path}: missing field(s) {missing}")
    if meta["agent"] not in DATA_FILES:
        raise CheckpointError(
            f"{path}: field 'agent' is {meta['agent']!r}, expected one of {sorted(DATA_FILES)}"
        )
    return meta


def checked_file(directory: str | os.PathLike[str], name: str) -> Path:
    """Path of file ``name`` of a checkpoint after checking its size and SHA-256 against
    ``meta.json``; CheckpointError if it is missing, undescribed, truncated or corrupt."""
    return check_file(Path(directory), name, read_meta(directory))


def check_file(directory: Path, name: str, meta: Mapping[str, Any]) -> Path:
    """``checked_file`` against an already read ``meta``."""
    path = directory / name
    expected = meta["files"].get(name) if isinstance(meta["files"], Mapping) else None
    if expected is None:
        raise CheckpointError(f"{directory / META_FILE}: field 'files' does not describe {name}")
    if not path.is_file():
        raise CheckpointError(f"{path}: missing")
    size = path.stat().st_size
    if size != expected.get("bytes"):
        raise CheckpointError(
            f"{path}: truncated or altered: {size} bytes, meta.json says {expected.get('bytes')}"
        )
    if digest(path)["sha256"] != expected.get("sha256"):
        raise CheckpointError(f"{path}: corrupt: SHA-256 differs from the one in meta.json")
    return path


def check_driven_as(
    root: Path,
    meta: Mapping[str, Any],
    expected_actions: ActionSet | None,
    expected_layout: Sequence[str] | None,
    reader: str,
) -> tuple[list[str], ActionSet]:
    """The checkpoint's (observation layout, action set) after checking them against what the
    caller feeds and expects (``load_checkpoint``'s arguments); CheckpointError naming meta.json
    on a mismatch."""
    meta_path = root / META_FILE
    obs = meta["observation"]
    layout = list(obs.get("layout", [])) if isinstance(obs, Mapping) else []
    dim = obs.get("dim") if isinstance(obs, Mapping) else None
    if dim != len(layout):
        raise CheckpointError(
            f"{meta_path}: observation dim {dim!r} disagrees with its layout of {len(layout)} names"
        )
    if expected_layout is not None and layout != list(expected_layout):
        have, want = kind_of_layout(layout), kind_of_layout(tuple(expected_layout))
        if have is not None and want is not None:
            raise CheckpointError(
                f"{meta_path}: the policy reads the {have!r} observation ({dim} entries) but "
                f"{reader} feeds the {want!r} observation ({len(expected_layout)} entries)"
            )
        raise CheckpointError(
            f"{meta_path}: observation layout {layout} (dim {dim}) differs from the expected "
            f"{list(expected_layout)} (dim {len(expected_layout)})"
        )
    try:
        actions = ActionSet.from_dict(meta["actions"])
    except ConfigError as err:
        raise CheckpointError(f"{meta_path}: field 'actions': {err}") from err
    if expected_actions is not None and actions != expected_actions:
        raise CheckpointError(
            f"{meta_path}: action set {actions.to_dict()} differs from the expected "
            f"{expected_actions.to_dict()}"
        )
    return layout, actions
