"""Loading a checkpoint: meta.json read and version-checked, every file's size and SHA-256
checked against it, the policy's terms checked (``policy_terms.folder_terms``), and the
tensors or Q-table checked for shape and finiteness before an agent is built."""

from __future__ import annotations

import os
import pickle
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.agent_types import Agent
from d3dwa_bullet.learning.agents.checkpoint_files import DATA_FILES, META_FILE
from d3dwa_bullet.learning.agents.checkpoint_meta import check_driven_as, check_file, read_meta
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.network import check_network_fits
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT


def load_checkpoint(
    directory: str | os.PathLike[str],
    *,
    expected_actions: ActionSet | None = None,
    expected_layout: Sequence[str] | None = OBSERVATION_LAYOUT,
    reader: str = "the caller",
) -> tuple[Agent, dict[str, Any]]:
    """Load an agent saved by ``save_checkpoint``: returns (agent, meta).

    expected_actions: if given, the checkpoint's action set must equal it.
    expected_layout: the observation names the caller will feed (default: the package's
    12-d layout); None skips the check. reader: who feeds it, for the message (a method). Any mismatch of layout, dimension, action set,
    format version, tensor shape, or a truncated/corrupt file raises CheckpointError naming
    the file and what did not match.
    """
    root = Path(directory)
    meta = read_meta(root)
    meta_path = root / META_FILE
    folder_terms(root)  # the terms it is driven on: well-formed, and its config.json's

    layout, actions = check_driven_as(root, meta, expected_actions, expected_layout, reader)

    family = meta["agent"]
    data = check_file(root, DATA_FILES[family], meta)
    try:
        if family == "d3qn":
            config = D3QNConfig.from_dict(meta["config"])
            check_network_fits(meta_path, data, len(layout), actions.size, config.hidden)
            agent: Agent = D3QNAgent(actions, config, layout)
        else:
            agent = DQDWAAgent(actions, DQDWAConfig.from_dict(meta["config"]))
    except (ConfigError, TypeError) as err:
        raise CheckpointError(f"{meta_path}: field 'config': {err}") from err
    if list(agent.obs_layout) != layout:
        raise CheckpointError(
            f"{meta_path}: observation layout {layout} does not fit a {family} agent "
            f"(which reads {list(agent.obs_layout)})"
        )

    if isinstance(agent, D3QNAgent):
        _load_weights(agent, data)
    else:
        _load_table(agent, data)
    agent.train_steps = int(meta["training_steps"])
    agent.env_steps = int(meta.get("env_steps", meta["training_steps"]))
    return agent, meta


def torch_load_failure(err: Exception) -> str:
    """One line on why ``torch.load(..., weights_only=True)`` refused a file.

    torch's own message for a pickle of Python objects runs to several lines and advises
    loading with ``weights_only=False``, which would run whatever code the file holds:
    that advice is never passed on; only the object torch refused is named.
    """
    text = str(err)
    if isinstance(err, pickle.UnpicklingError) or "weights_only" in text:
        refused = re.search(r"Unsupported global: GLOBAL ([\w.]+)", text)
        what = f" such as {refused.group(1)}" if refused else ""
        return (
            f"it holds pickled Python objects{what}, which the safe loader refuses; this "
            "package's checkpoints hold tensors only"
        )
    lines = "; ".join(line.strip() for line in text.splitlines() if line.strip())
    return f"{type(err).__name__}: {lines}"


def _load_weights(agent: D3QNAgent, path: Path) -> None:
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # torch raises many types for a damaged pickle/zip
        raise CheckpointError(
            f"{path}: cannot be read as tensors ({torch_load_failure(err)})"
        ) from err
    if not isinstance(state, Mapping) or not all(
        isinstance(v, torch.Tensor) for v in state.values()
    ):
        raise CheckpointError(
            f"{path}: expected a state_dict of tensors, got {type(state).__name__}"
        )
    expected = agent.state_dict()
    missing = sorted(set(expected) - set(state))
    unexpected = sorted(set(state) - set(expected))
    if missing or unexpected:
        raise CheckpointError(
            f"{path}: tensor names differ: missing {missing}, unexpected {unexpected}"
        )
    for key, ref in expected.items():
        got = state[key]
        if tuple(got.shape) != tuple(ref.shape) or got.dtype != ref.dtype:
            raise CheckpointError(
                f"{path}: tensor {key!r} has shape {tuple(got.shape)} {got.dtype}, the network "
                f"described by meta.json needs {tuple(ref.shape)} {ref.dtype}"
            )
        if not torch.isfinite(got).all():
            raise CheckpointError(f"{path}: tensor {key!r} holds NaN or inf")
    agent.load_state_dict(state)


def _load_table(agent: DQDWAAgent, path: Path) -> None:
    try:
        table = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise CheckpointError(f"{path}: cannot be read as a .npy array ({err})") from err
    if table.shape != agent.table.shape or table.dtype != agent.table.dtype:
        raise CheckpointError(
            f"{path}: Q-table has shape {table.shape} {table.dtype}, meta.json describes "
            f"{agent.table.shape} {agent.table.dtype} (states x actions)"
        )
    if not np.all(np.isfinite(table)):
        raise CheckpointError(f"{path}: Q-table holds NaN or inf")
    agent.table[...] = table
