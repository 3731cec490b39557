"""The guard before an ONNX file runs: a file is a program, so it is not trusted. It must be
a regular file under ``MAX_POLICY_BYTES``, describe itself (``onnx_description``), hold a graph
of the kind the exporter writes (``onnx_graph.check_graph``: its operators, weights inside the
file, bounded memory and work per inference) and a signature that fits its description, all
before onnxruntime makes a session of it. onnx and onnxruntime are imported only here, when
a file is checked (the optional ``robot`` extra)."""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.onnx_description import INPUT_NAME, OUTPUT_NAME, read_metadata
from d3dwa_bullet.learning.agents.onnx_graph import GraphCost, check_graph
from d3dwa_bullet.learning.agents.onnx_run import ONE_LINE
from d3dwa_bullet.limits import MAX_POLICY_BYTES

INSTALL_HINT = "pip install 'd3dwa-bullet[robot]'"
PROBE_OBSERVATIONS = 64
"""Sampled observations (and the all-zero one) a file's Q-values must be finite on to load."""
SIGNED_ENTRIES = frozenset({"theta_goal", "v", "w"})
"""Observation entries in [-1, 1] (bearing, velocities); every other entry is in [0, 1]."""


def sample_observations(layout: Sequence[str], n: int, seed: int) -> np.ndarray:
    """(n, len(layout)) float32 observations in their entries' ranges (SIGNED_ENTRIES in
    [-1, 1], the rest in [0, 1]), uniform, from ``seed``: what a check or a benchmark feeds."""
    rng = np.random.default_rng(seed)
    low = np.array([-1.0 if name in SIGNED_ENTRIES else 0.0 for name in layout])
    return rng.uniform(low, 1.0, (n, len(layout))).astype(np.float32)


def read_model_bytes(path: Path) -> bytes:
    """The bytes of a model file; CheckpointError if it is missing, not a regular file (a
    FIFO would block) or over MAX_POLICY_BYTES."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise CheckpointError(f"{path}: missing (no ONNX policy there)") from None
    except OSError as err:
        raise CheckpointError(f"{path}: cannot read: {err.strerror or err}") from err
    if not stat.S_ISREG(mode):
        what = "a directory" if stat.S_ISDIR(mode) else "not a regular file"
        raise CheckpointError(f"{path}: {what}; an ONNX policy is one .onnx file")
    try:
        with open(path, "rb") as fh:
            MAX_POLICY_BYTES.check(
                f"{path}", os.fstat(fh.fileno()).st_size, "bytes", CheckpointError
            )
            data = fh.read(int(MAX_POLICY_BYTES.value) + 1)
    except OSError as err:
        raise CheckpointError(f"{path}: cannot read: {err.strerror or err}") from err
    MAX_POLICY_BYTES.check(f"{path}", len(data), "bytes", CheckpointError)
    return data


def checked_session(data: bytes, where: str) -> tuple[dict[str, Any], GraphCost, Any]:
    """(metadata, graph cost, onnxruntime session) of a model whose description and graph
    pass (``read_metadata``, ``onnx_graph.check_graph``); the session is made last."""
    try:
        # optional dependency: onnx (the `robot` extra) parses the file before it is run
        import onnx
    except ImportError as err:
        raise CheckpointError(
            f"{where}: cannot check an ONNX policy: the onnx package is not installed "
            f"({INSTALL_HINT})"
        ) from err
    try:
        model = onnx.load_model_from_string(data)
    except Exception as err:  # protobuf's DecodeError, or onnx's own
        reason = " ".join(str(err).split())[:ONE_LINE]
        raise CheckpointError(
            f"{where}: not an ONNX model onnxruntime can load ({type(err).__name__}: {reason})"
        ) from err
    meta = read_metadata({p.key: p.value for p in model.metadata_props}, where)
    cost = check_graph(model, where, INPUT_NAME, OUTPUT_NAME)
    return meta, cost, _session(data, where)


def _session(data: bytes, where: str) -> Any:
    try:
        # optional dependency: onnxruntime is the `robot` extra, needed only to run ONNX files
        import onnxruntime
    except ImportError as err:
        raise CheckpointError(
            f"{where}: cannot run an ONNX policy: onnxruntime is not installed ({INSTALL_HINT})"
        ) from err
    options = onnxruntime.SessionOptions()
    # A 12-d MLP runs fastest on one thread, and the control loop keeps the other cores.
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.log_severity_level = 3  # errors only: its warnings would interleave with ours
    try:
        return onnxruntime.InferenceSession(
            data, sess_options=options, providers=["CPUExecutionProvider"]
        )
    except Exception as err:  # onnxruntime raises its own types (InvalidProtobuf, Fail, ...)
        reason = " ".join(str(err).split())[:ONE_LINE]
        raise CheckpointError(
            f"{where}: not an ONNX model onnxruntime can load ({type(err).__name__}: {reason})"
        ) from err


def check_signature(session: Any, obs_dim: int, n_actions: int, where: str) -> None:
    """One float input ``obs`` (B, obs_dim) and output ``q`` (B, n_actions), as the metadata says."""
    inputs, outputs = session.get_inputs(), session.get_outputs()
    got_in = [(i.name, i.type, list(i.shape)) for i in inputs]
    got_out = [(o.name, o.type, list(o.shape)) for o in outputs]
    ok = (
        len(inputs) == 1
        and len(outputs) == 1
        and (inputs[0].name, inputs[0].type) == (INPUT_NAME, "tensor(float)")
        and (outputs[0].name, outputs[0].type) == (OUTPUT_NAME, "tensor(float)")
        and len(inputs[0].shape) == 2
        and inputs[0].shape[1] == obs_dim
        and len(outputs[0].shape) == 2
        and outputs[0].shape[1] == n_actions
    )
    if not ok:
        raise CheckpointError(
            f"{where}: graph inputs {got_in} and outputs {got_out} do not fit its metadata, "
            f"which needs {INPUT_NAME!r} float (B, {obs_dim}) -> {OUTPUT_NAME!r} float "
            f"(B, {n_actions})"
        )
