"""Checkpoints: a directory with the learned values and a ``meta.json`` describing them.

Layout::

    <dir>/meta.json     format version, agent family, method name, observation layout,
                        action set, config, step counts, package version, and the size and
                        SHA-256 of every data file (so truncation and corruption are caught)
    <dir>/weights.pt    D3QN: the online network's state_dict (tensors only)
    <dir>/table.npy     DQDWA: the Q-table, (n_states, n_actions) float64
    <dir>/weights.npz   D3QN, optional: weights.pt's tensors for torch-free evaluation (``numpy_policy``)

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

Modules: ``checkpoint_files`` (names and digests), ``checkpoint_save``, ``checkpoint_load``;
the terms a policy is driven on are ``policy_terms``'. The policy files alone stay loadable by ``load_checkpoint``/``load_policy``; shipped
policies carry no training state.
"""

from __future__ import annotations

from d3dwa_bullet.learning.agents.agent_types import Agent
from d3dwa_bullet.learning.agents.checkpoint_files import (
    CONFIG_FILE,
    CURVE_FILE,
    EXTRA_FILES,
    FORMAT_VERSION,
    META_FILE,
    NUMPY_WEIGHTS_FILE,
    REPLAY_FILE,
    SUMMARY_FILE,
    TABLE_FILE,
    TRAINING_STATE_FILE,
    TRAINING_TENSORS_FILE,
    WEIGHTS_FILE,
)
from d3dwa_bullet.learning.agents.checkpoint_load import load_checkpoint, torch_load_failure
from d3dwa_bullet.learning.agents.checkpoint_meta import checked_file, read_meta
from d3dwa_bullet.learning.agents.checkpoint_save import default_method, save_checkpoint

__all__ = [
    "CONFIG_FILE",
    "CURVE_FILE",
    "NUMPY_WEIGHTS_FILE",
    "EXTRA_FILES",
    "FORMAT_VERSION",
    "META_FILE",
    "REPLAY_FILE",
    "SUMMARY_FILE",
    "TABLE_FILE",
    "TRAINING_STATE_FILE",
    "TRAINING_TENSORS_FILE",
    "WEIGHTS_FILE",
    "Agent",
    "checked_file",
    "default_method",
    "load_checkpoint",
    "read_meta",
    "save_checkpoint",
    "torch_load_failure",
]
