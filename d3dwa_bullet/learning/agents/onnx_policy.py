"""The greedy policy of an exported ONNX file, run by onnxruntime: no torch (SPEC section 10).

An exported policy (``onnx_export.export_onnx``, ``d3dwa export --onnx``) is one graph:
input ``obs`` (B, obs_dim) float32 -> output ``q`` (B, |A|) float32, the dueling Q-values
V + A - mean A of every action, B free. Its ``metadata_props`` (string keys ``d3dwa.*``, see
``METADATA_KEYS``) say what a runner needs and nothing else can tell it: the method, the
observation kind and the names of its entries, the action set (rebuilt here as an
``ActionSet`` and checked against the caller's), the decision period and the recovery layer
the policy trained inside (``policy_terms``; a file exported before they were recorded lacks
them, which means period 1 and no recovery layer), the source checkpoint (weights digest,
step counts, network widths) and the format version of this description.

``load_onnx_policy`` mirrors ``policy.load_policy``: (policy, action set, meta), and a
``CheckpointError`` of one line naming the file for anything that does not fit (not a file,
not ONNX, not ours, another format version, another observation kind or action set, a graph
whose signature disagrees with its metadata, onnx or onnxruntime not installed).

A file is a program, so it is not trusted: before onnxruntime sees it, its graph must be
the kind the exporter writes (``onnx_graph.check_graph``: its operators, weights inside the
file, bounded memory and work per inference), and its Q-values on ``PROBE_OBSERVATIONS``
observations must come out finite. Then at every inference, a failure of the runtime, an
output of the wrong shape or a NaN or inf Q-value is a CheckpointError naming the file:
no action is ever chosen from values that are not numbers.

Modules: ``onnx_description`` (the description), ``onnx_guard`` (the checks before a file runs),
``onnx_run`` (``OnnxGreedyPolicy``) and this one, which loads. This module imports numpy, the pure planning layer and ``policy_terms`` only, never torch;
onnx and onnxruntime are imported when a file is loaded (the optional ``robot`` extra). The
greedy action is the argmax of the Q-values (the lowest index on an exact tie, as numpy's
argmax); it agrees with the torch and numpy policies except where two Q-values tie to within
float32 rounding.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.onnx_description import (
    INPUT_NAME,
    METADATA_KEYS,
    ONNX_FORMAT_VERSION,
    OPTIONAL_FIELDS,
    OUTPUT_NAME,
    READ_VERSIONS,
    metadata_props,
    read_metadata,
)
from d3dwa_bullet.learning.agents.onnx_guard import (
    INSTALL_HINT,
    PROBE_OBSERVATIONS,
    SIGNED_ENTRIES,
    check_signature,
    checked_session,
    read_model_bytes,
    sample_observations,
)
from d3dwa_bullet.learning.agents.onnx_run import OnnxGreedyPolicy
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import observation_layout

__all__ = [
    "INPUT_NAME",
    "INSTALL_HINT",
    "METADATA_KEYS",
    "ONNX_FORMAT_VERSION",
    "OPTIONAL_FIELDS",
    "OUTPUT_NAME",
    "PROBE_OBSERVATIONS",
    "READ_VERSIONS",
    "SIGNED_ENTRIES",
    "OnnxGreedyPolicy",
    "load_onnx_policy",
    "metadata_props",
    "onnx_metadata",
    "onnx_policy_from_bytes",
    "read_metadata",
    "read_model_bytes",
    "sample_observations",
]


def load_onnx_policy(
    file: str | os.PathLike[str],
    *,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] = ("paper", "the caller"),
) -> tuple[OnnxGreedyPolicy, ActionSet, dict[str, Any]]:
    """Greedy policy of an exported ONNX file: (policy, action set, meta), as ``load_policy``.

    expected_observation: (kind, who feeds it), as in ``load_policy``. meta: the parsed
    metadata (``read_metadata``) plus ``file``. CheckpointError (one line naming the file)
    for anything that does not fit; see the module docstring.
    """
    path = Path(file)
    return onnx_policy_from_bytes(
        read_model_bytes(path),
        str(path),
        expected_actions=expected_actions,
        expected_observation=expected_observation,
    )


def onnx_metadata(file: str | os.PathLike[str]) -> dict[str, Any]:
    """What an exported file says about itself (``read_metadata``'s dict plus ``file``),
    checked as ``load_onnx_policy`` checks it but against no method: for a caller that
    takes the method from the file (``meta["method"]``) before loading it for that method."""
    path = Path(file)
    meta, _, session = checked_session(read_model_bytes(path), str(path))
    check_signature(session, meta["observation"]["dim"], meta["actions"].size, str(path))
    meta["file"] = str(path)
    return meta


def onnx_policy_from_bytes(
    data: bytes,
    where: str,
    *,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] = ("paper", "the caller"),
) -> tuple[OnnxGreedyPolicy, ActionSet, dict[str, Any]]:
    """``load_onnx_policy`` of a model already in memory (``where`` names it in messages)."""
    meta, cost, session = checked_session(data, where)
    actions: ActionSet = meta["actions"]
    kind, reader = expected_observation
    have = meta["observation"]
    if have["kind"] != kind:
        want = observation_layout(kind)
        raise CheckpointError(
            f"{where}: the policy reads the {have['kind']!r} observation ({have['dim']} "
            f"entries) but {reader} feeds the {kind!r} observation ({len(want)} entries)"
        )
    if expected_actions is not None and actions != expected_actions:
        raise CheckpointError(
            f"{where}: the policy's action set {actions.to_dict()} differs from the "
            f"{expected_actions.to_dict()} {reader} decodes"
        )
    check_signature(session, have["dim"], actions.size, where)
    policy = OnnxGreedyPolicy(session, have["dim"], actions.size, where, cost)
    probe = sample_observations(have["layout"], PROBE_OBSERVATIONS, seed=0)
    policy.q_values(np.vstack([np.zeros((1, have["dim"]), dtype=np.float32), probe]))
    meta["file"] = where
    return policy, actions, meta
