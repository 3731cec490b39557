"""Saving a checkpoint: every file written and fsynced into a temporary sibling directory
that then replaces the old one, so a checkpoint is always whole (``checkpoint``)."""

from __future__ import annotations

import io
import json
import os
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import CheckpointError, WriteError
from d3dwa_bullet.learning.agents.agent_types import Agent
from d3dwa_bullet.learning.agents.checkpoint_files import (
    CHECKPOINT_FILES,
    DATA_FILES,
    EXTRA_FILES,
    FORMAT_VERSION,
    META_FILE,
    digest,
    fsync,
)
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY


def default_method(agent: Agent) -> str:
    """The method name (docs/design/methods.md#methods) an agent stands for, from its family and action set."""
    if isinstance(agent, DQDWAAgent):
        return "dqdwa"
    if agent.actions == ACTIONS_FULL:
        return "d3dwa"
    if agent.actions == ACTIONS_WEIGHTS_ONLY:
        return "d3dwa-weights"
    return "d3qn-custom"


def save_checkpoint(
    directory: str | os.PathLike[str],
    agent: Agent,
    metadata: Mapping[str, Any] | None = None,
    *,
    method: str | None = None,
    extra_files: Mapping[str, bytes | os.PathLike[str]] | None = None,
) -> Path:
    """Write ``agent`` to ``directory`` atomically and return the directory's path.

    metadata: free-form JSON-serialisable run information (world list, profile, run name,
    ...), stored under ``meta["metadata"]``. method: the method name recorded in the
    checkpoint (default: ``metadata["method"]`` if given, else ``default_method(agent)``).
    extra_files: name -> content (bytes) or a file to copy, for names in ``EXTRA_FILES``;
    written into the same atomic swap and digested in ``meta["files"]``.
    An existing checkpoint at ``directory`` is replaced; a directory holding anything else
    raises CheckpointError rather than being deleted.
    """
    target = Path(directory)
    extra = dict(metadata or {})
    extras = dict(extra_files or {})
    bad = sorted(set(extras) - EXTRA_FILES)
    if bad:
        raise CheckpointError(
            f"{target}: extra file name(s) {bad} not allowed; use {sorted(EXTRA_FILES)}"
        )
    if target.exists():
        if not target.is_dir():
            raise CheckpointError(f"{target}: exists and is not a directory")
        foreign = sorted(p.name for p in target.iterdir() if p.name not in CHECKPOINT_FILES)
        if foreign:
            raise CheckpointError(
                f"{target}: refusing to replace a directory holding non-checkpoint files {foreign}"
            )
    target.parent.mkdir(parents=True, exist_ok=True)
    family = agent.method_family
    meta: dict[str, Any] = {
        "format_version": FORMAT_VERSION,
        "package_version": __version__,
        "agent": family,
        "method": method or str(extra.get("method") or default_method(agent)),
        "observation": {"layout": list(agent.obs_layout), "dim": agent.obs_dim},
        "actions": agent.actions.to_dict(),
        "config": agent.config.to_dict(),
        "training_steps": agent.train_steps,
        "env_steps": agent.env_steps,
        "files": {},
        "metadata": extra,
    }
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.tmp-", dir=target.parent))
    try:
        data, buffer = tmp / DATA_FILES[family], io.BytesIO()  # torch.save(state, data)
        if isinstance(agent, D3QNAgent):  # would end a full disk in a RuntimeError, not OSError
            state = {k: v.detach().clone().contiguous() for k, v in agent.state_dict().items()}
            torch.save(state, buffer)
        else:
            np.save(buffer, agent.table, allow_pickle=False)
        data.write_bytes(buffer.getvalue())
        fsync(data)
        meta["files"][data.name] = digest(data)
        for name, content in sorted(extras.items()):
            path = tmp / name
            if isinstance(content, bytes | bytearray):
                path.write_bytes(content)
            else:
                shutil.copyfile(content, path)
            fsync(path)
            meta["files"][name] = digest(path)
        try:
            text = json.dumps(meta, indent=2, sort_keys=True, allow_nan=False)
        except (TypeError, ValueError) as err:
            raise CheckpointError(
                f"{target / META_FILE}: metadata is not JSON-serialisable: {err}"
            ) from err
        (tmp / META_FILE).write_text(text + "\n", encoding="utf-8")
        fsync(tmp / META_FILE)
        _swap_in(tmp, target)
    except OSError as err:  # a full disk, the file-size limit: the old checkpoint stays
        raise WriteError(target, err) from err
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return target


def _swap_in(tmp: Path, target: Path) -> None:
    """Move the finished ``tmp`` directory to ``target``, replacing an old checkpoint.

    A directory rename cannot overwrite a non-empty directory, so the old one is first
    renamed aside; ``target`` is thus always either the old or the new complete checkpoint
    (or briefly absent), never a mix.
    """
    old: Path | None = None
    if target.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
        os.replace(target, old / "ckpt")
    try:
        os.replace(tmp, target)
    except BaseException:
        if old is not None:
            os.replace(old / "ckpt", target)
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    dir_fd = os.open(target.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)
