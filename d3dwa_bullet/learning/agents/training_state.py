"""The training state of an agent: what a checkpoint needs beyond the policy to resume exactly.

``training_state_files`` turns an agent (and the training loop's own state) into the extra
files of ``checkpoint.EXTRA_FILES``; ``restore_training_state`` puts them back into an
agent just loaded by ``load_checkpoint`` from the same directory::

    training_state.json   step counters, RNG states (agent, replay), the trainer's state
    training_state.pt     D3QN: target network, Adam state and torch RNG (tensors and plain
                          values only: torch.load(weights_only=True) reads it)
    replay.npz            D3QN: the replay buffer's stored transitions (np.savez)

Every file is digested in ``meta.json`` like the policy's own data file, so a truncated or
altered training state is a CheckpointError, never a silently different resumption.
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import (
    FORMAT_VERSION,
    REPLAY_FILE,
    TRAINING_STATE_FILE,
    TRAINING_TENSORS_FILE,
    Agent,
    checked_file,
    torch_load_failure,
)
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.loading import load_json


def _rng_state(rng: np.random.Generator) -> dict[str, Any]:
    return rng.bit_generator.state


def _set_rng_state(rng: np.random.Generator, state: Mapping[str, Any], where: str) -> None:
    try:
        rng.bit_generator.state = dict(state)
    except (TypeError, ValueError, KeyError) as err:
        raise CheckpointError(f"{where}: unusable RNG state ({err})") from err


def training_state_files(agent: Agent, trainer: Mapping[str, Any]) -> dict[str, bytes]:
    """The training-state files (module docstring) of ``agent`` plus the trainer's state.

    trainer: JSON-serialisable state of the training loop, stored under ``"trainer"``.
    Pass the result as ``extra_files`` to ``save_checkpoint``.
    """
    state: dict[str, Any] = {
        "format_version": FORMAT_VERSION,
        "agent": agent.method_family,
        "env_steps": agent.env_steps,
        "train_steps": agent.train_steps,
        "epsilon": agent.epsilon(),
        "agent_rng": _rng_state(agent._rng),
        "n_step_windows": agent.n_step_windows.state(),
        "trainer": dict(trainer),
    }
    files: dict[str, bytes] = {}
    if isinstance(agent, D3QNAgent):
        tensors: dict[str, Any] = {
            "target": {k: v.detach().clone() for k, v in agent.target.state_dict().items()},
            "optimizer": agent.optimizer.state_dict(),
            "torch_rng": torch.get_rng_state(),
        }
        buf = io.BytesIO()
        torch.save(tensors, buf)
        files[TRAINING_TENSORS_FILE] = buf.getvalue()
        replay = agent.replay
        n = len(replay)
        state["replay"] = {
            "capacity": replay.capacity,
            "size": n,
            "pos": replay._pos,
            "rng": _rng_state(replay._rng),
        }
        buf = io.BytesIO()
        np.savez(
            buf,
            obs=replay._obs[:n],
            next_obs=replay._next_obs[:n],
            actions=replay._actions[:n],
            rewards=replay._rewards[:n],
            terminated=replay._terminated[:n],
            discounts=replay._discounts[:n],
        )
        files[REPLAY_FILE] = buf.getvalue()
    else:  # the tabular agent: its table is the checkpoint's data file
        state["visits"] = agent.visits.tolist()
    try:
        text = json.dumps(state, indent=1, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as err:
        raise CheckpointError(f"training state is not JSON-serialisable: {err}") from err
    files[TRAINING_STATE_FILE] = text.encode("utf-8")
    return files


def restore_training_state(directory: str | os.PathLike[str], agent: Agent) -> dict[str, Any]:
    """Put the training state saved in ``directory`` into ``agent`` (just loaded from the
    same checkpoint by ``load_checkpoint``) and return the trainer's state.

    Restores counters, the exploration and replay RNGs, and for a D3QN the target network,
    the Adam moments and the replay buffer; CheckpointError if a file is missing, corrupt or
    does not fit the agent.
    """
    root = Path(directory)
    path = checked_file(root, TRAINING_STATE_FILE)
    state = load_json(path, CheckpointError, "training state")
    if not isinstance(state, dict):
        raise CheckpointError(f"{path}: expected a JSON object, got {type(state).__name__}")
    if state.get("format_version") != FORMAT_VERSION or state.get("agent") != agent.method_family:
        raise CheckpointError(
            f"{path}: training state of agent {state.get('agent')!r} (format "
            f"{state.get('format_version')!r}) does not fit a {agent.method_family} agent"
        )
    agent.env_steps = int(state["env_steps"])
    agent.train_steps = int(state["train_steps"])
    _set_rng_state(agent._rng, state["agent_rng"], str(path))
    if isinstance(agent, D3QNAgent):
        tpath = checked_file(root, TRAINING_TENSORS_FILE)
        try:
            tensors = torch.load(tpath, map_location="cpu", weights_only=True)
            agent.target.load_state_dict(tensors["target"])
            agent.optimizer.load_state_dict(tensors["optimizer"])
            torch.set_rng_state(tensors["torch_rng"])
        except Exception as err:  # torch raises many types for a damaged or mismatched file
            raise CheckpointError(
                f"{tpath}: cannot restore target network / optimizer ({torch_load_failure(err)})"
            ) from err
        info = state["replay"]
        replay = agent.replay
        if info["capacity"] != replay.capacity:
            raise CheckpointError(
                f"{path}: replay capacity {info['capacity']} differs from the agent's {replay.capacity}"
            )
        rpath = checked_file(root, REPLAY_FILE)
        n = int(info["size"])
        try:
            with np.load(rpath, allow_pickle=False) as data:
                for name in ("obs", "next_obs", "actions", "rewards", "terminated"):
                    getattr(replay, f"_{name}")[:n] = data[name]
                # a checkpoint from before n-step returns stored one-step transitions only
                replay._discounts[:n] = (
                    data["discounts"] if "discounts" in data.files else agent.config.gamma
                )
        except (OSError, ValueError, KeyError) as err:
            raise CheckpointError(f"{rpath}: cannot restore the replay buffer ({err})") from err
        replay._size, replay._pos = n, int(info["pos"])
        _set_rng_state(replay._rng, info["rng"], str(path))
    else:
        _restore_visits(agent, state.get("visits"), str(path))
    agent.n_step_windows.load_state(state.get("n_step_windows", {}), str(path))
    return dict(state["trainer"])


def _restore_visits(agent: DQDWAAgent, visits: Any, where: str) -> None:
    """The tabular agent's update counts; a state from before they were kept restores none
    (only ``alpha_schedule: visits`` reads them)."""
    if visits is None:
        agent.visits[...] = 0
        return
    try:
        counts = np.asarray(visits, dtype=np.int64)
    except (TypeError, ValueError, OverflowError) as err:
        raise CheckpointError(f"{where}: field 'visits' is not a table of counts ({err})") from err
    if counts.shape != agent.visits.shape or (counts < 0).any():
        raise CheckpointError(
            f"{where}: field 'visits' has shape {counts.shape} (or a negative count), the "
            f"Q-table is {agent.visits.shape}"
        )
    agent.visits[...] = counts
