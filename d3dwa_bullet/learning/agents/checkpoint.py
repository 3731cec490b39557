"""Checkpoints: a directory with the learned values and a ``meta.json`` describing them.

Layout::

    <dir>/meta.json     format version, agent family, method name, observation layout,
                        action set, config, step counts, package version, and the size and
                        SHA-256 of every data file (so truncation and corruption are caught)
    <dir>/weights.pt    D3QN: the online network's state_dict (tensors only)
    <dir>/table.npy     DQDWA: the Q-table, (n_states, n_actions) float64

Saving is atomic: everything is written and fsynced into a temporary sibling directory
that then replaces ``<dir>``; if anything fails before that, an existing checkpoint is left
exactly as it was. A D3QN checkpoint holds the online weights only (the target network is
re-initialised to them on load; optimizer moments and the replay buffer are not kept): it
is for evaluation and warm starts.

A checkpoint may also carry the files of ``EXTRA_FILES`` (``extra_files=`` of
``save_checkpoint``), digested in ``meta.json`` like the data file. Training uses them
for the run's ``config.json`` and ``learning_curve.png``, and for the *training state*
that makes resumption exact (written and read by ``training_state``)::

    <dir>/training_state.json   step counters, RNG states (agent, replay, trainer), the
                                trainer's own state (episode in progress, curriculum, ...)
    <dir>/training_state.pt     D3QN: target network and Adam state (tensors and plain
                                values only: torch.load(weights_only=True) reads it)
    <dir>/replay.npz            D3QN: the replay buffer's stored transitions (np.savez)

The policy files alone stay loadable by ``load_checkpoint``/``load_policy``; shipped
policies carry no training state.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import re
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import CheckpointError, ConfigError, WriteError
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.network import check_network_fits
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY, ActionSet
from d3dwa_bullet.planning.observation import OBSERVATION_LAYOUT
from d3dwa_bullet.planning.progress import kind_of_layout

FORMAT_VERSION = 1
META_FILE = "meta.json"
WEIGHTS_FILE = "weights.pt"
TABLE_FILE = "table.npy"
CONFIG_FILE = "config.json"
CURVE_FILE = "learning_curve.png"
SUMMARY_FILE = "summary.json"
"""A training run's summary; an exported policy carries it (counters, evaluations, wall time)."""
TRAINING_STATE_FILE = "training_state.json"
TRAINING_TENSORS_FILE = "training_state.pt"
REPLAY_FILE = "replay.npz"
_DATA_FILES = {"d3qn": WEIGHTS_FILE, "dqdwa": TABLE_FILE}
#: Files a checkpoint may carry besides the policy (see module docstring).
EXTRA_FILES = frozenset(
    {CONFIG_FILE, CURVE_FILE, SUMMARY_FILE, TRAINING_STATE_FILE, TRAINING_TENSORS_FILE, REPLAY_FILE}
)
_CHECKPOINT_FILES = {META_FILE, WEIGHTS_FILE, TABLE_FILE} | EXTRA_FILES

Agent = D3QNAgent | DQDWAAgent


def default_method(agent: Agent) -> str:
    """The method name (docs/design.md#methods) an agent stands for, from its family and action set."""
    if isinstance(agent, DQDWAAgent):
        return "dqdwa"
    if agent.actions == ACTIONS_FULL:
        return "d3dwa"
    if agent.actions == ACTIONS_WEIGHTS_ONLY:
        return "d3dwa-weights"
    return "d3qn-custom"


def _digest(path: Path) -> dict[str, Any]:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return {"bytes": path.stat().st_size, "sha256": h.hexdigest()}


def _fsync(path: Path) -> None:
    with open(path, "rb") as f:
        os.fsync(f.fileno())


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
        foreign = sorted(p.name for p in target.iterdir() if p.name not in _CHECKPOINT_FILES)
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
        data, buffer = tmp / _DATA_FILES[family], io.BytesIO()  # torch.save(state, data)
        if isinstance(agent, D3QNAgent):  # would end a full disk in a RuntimeError, not OSError
            state = {k: v.detach().clone().contiguous() for k, v in agent.state_dict().items()}
            torch.save(state, buffer)
        else:
            np.save(buffer, agent.table, allow_pickle=False)
        data.write_bytes(buffer.getvalue())
        _fsync(data)
        meta["files"][data.name] = _digest(data)
        for name, content in sorted(extras.items()):
            path = tmp / name
            if isinstance(content, bytes | bytearray):
                path.write_bytes(content)
            else:
                shutil.copyfile(content, path)
            _fsync(path)
            meta["files"][name] = _digest(path)
        try:
            text = json.dumps(meta, indent=2, sort_keys=True, allow_nan=False)
        except (TypeError, ValueError) as err:
            raise CheckpointError(
                f"{target / META_FILE}: metadata is not JSON-serialisable: {err}"
            ) from err
        (tmp / META_FILE).write_text(text + "\n", encoding="utf-8")
        _fsync(tmp / META_FILE)
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
    if meta["agent"] not in _DATA_FILES:
        raise CheckpointError(
            f"{path}: field 'agent' is {meta['agent']!r}, expected one of {sorted(_DATA_FILES)}"
        )
    return meta


def checked_file(directory: str | os.PathLike[str], name: str) -> Path:
    """Path of file ``name`` of a checkpoint after checking its size and SHA-256 against
    ``meta.json``; CheckpointError if it is missing, undescribed, truncated or corrupt."""
    return _check_file(Path(directory), name, read_meta(directory))


def _check_file(directory: Path, name: str, meta: Mapping[str, Any]) -> Path:
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
    if _digest(path)["sha256"] != expected.get("sha256"):
        raise CheckpointError(f"{path}: corrupt: SHA-256 differs from the one in meta.json")
    return path


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

    family = meta["agent"]
    data = _check_file(root, _DATA_FILES[family], meta)
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
