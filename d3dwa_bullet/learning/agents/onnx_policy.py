"""The greedy policy of an exported ONNX file, run by onnxruntime: no torch (SPEC section 10).

An exported policy (``onnx_export.export_onnx``, ``d3dwa export --onnx``) is one graph:
input ``obs`` (B, obs_dim) float32 -> output ``q`` (B, |A|) float32, the dueling Q-values
V + A - mean A of every action, B free. Its ``metadata_props`` (string keys ``d3dwa.*``, see
``METADATA_KEYS``) say what a runner needs and nothing else can tell it: the method, the
observation kind and the names of its entries, the action set (rebuilt here as an
``ActionSet`` and checked against the caller's), the source checkpoint (weights digest, step
counts, network widths) and the format version of this description.

``load_onnx_policy`` mirrors ``policy.load_policy``: (policy, action set, meta), and a
``CheckpointError`` of one line naming the file for anything that does not fit (not a file,
not ONNX, not ours, another format version, another observation kind or action set, a graph
whose signature disagrees with its metadata, onnxruntime not installed).

This module imports numpy and the pure planning layer only, never torch; onnxruntime is
imported when a file is loaded (it is the optional ``robot`` extra). The greedy action is
the argmax of the Q-values (the lowest index on an exact tie, as numpy's argmax); it agrees
with the torch and numpy policies except where two Q-values tie to within float32 rounding.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.limits import MAX_POLICY_BYTES
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.progress import LAYOUTS, observation_layout

ONNX_FORMAT_VERSION = 1
"""Version of the metadata described here; a runner reads only its own version."""
INPUT_NAME = "obs"
OUTPUT_NAME = "q"
METADATA_KEYS = {
    "format_version": "d3dwa.format_version",  # ONNX_FORMAT_VERSION, decimal
    "method": "d3dwa.method",  # the method it was exported for: d3dwa, d3dwa-pa, ...
    "observation_kind": "d3dwa.observation.kind",  # paper | progress
    "observation_layout": "d3dwa.observation.layout",  # JSON list of entry names
    "obs_dim": "d3dwa.observation.dim",  # decimal, == len(layout)
    "actions": "d3dwa.actions",  # JSON of ActionSet.to_dict()
    "source": "d3dwa.source",  # JSON: the checkpoint's digest, steps, config, run
}
"""Field -> metadata_props key of an exported policy."""
INSTALL_HINT = "pip install 'd3dwa-bullet[robot]'"
_ONE_LINE = 300  # characters of a library's own message kept in ours


def metadata_props(
    method: str, kind: str, actions: ActionSet, source: Mapping[str, Any]
) -> dict[str, str]:
    """The metadata_props of a policy for ``method`` reading observation ``kind`` (the
    exporter's half of the description ``read_metadata`` checks)."""
    layout = observation_layout(kind)
    return {
        METADATA_KEYS["format_version"]: str(ONNX_FORMAT_VERSION),
        METADATA_KEYS["method"]: method,
        METADATA_KEYS["observation_kind"]: kind,
        METADATA_KEYS["observation_layout"]: json.dumps(list(layout)),
        METADATA_KEYS["obs_dim"]: str(len(layout)),
        METADATA_KEYS["actions"]: json.dumps(actions.to_dict(), sort_keys=True),
        METADATA_KEYS["source"]: json.dumps(dict(source), sort_keys=True, allow_nan=False),
    }


def read_metadata(props: Mapping[str, str], where: str) -> dict[str, Any]:
    """Parse and check metadata_props: {format_version, method, observation: {kind, layout,
    dim}, actions: ActionSet, source}. CheckpointError naming ``where`` and the key."""
    version_key = METADATA_KEYS["format_version"]
    if version_key not in props:
        ours = sorted(k for k in props if k.startswith("d3dwa."))
        raise CheckpointError(
            f"{where}: not a d3dwa policy: its metadata has no {version_key!r}"
            + (f" (only {ours})" if ours else "")
            + "; export one with `d3dwa export --onnx DIR`"
        )
    if props[version_key] != str(ONNX_FORMAT_VERSION):
        raise CheckpointError(
            f"{where}: metadata {version_key} is {props[version_key]!r}, this code reads "
            f"version {ONNX_FORMAT_VERSION}"
        )
    missing = [k for k in METADATA_KEYS.values() if k not in props]
    if missing:
        raise CheckpointError(f"{where}: metadata lacks {missing}")

    def parsed(field: str) -> Any:
        key = METADATA_KEYS[field]
        return parse_json(props[key], CheckpointError, f"{where}: metadata {key}")

    kind = props[METADATA_KEYS["observation_kind"]]
    if kind not in LAYOUTS:
        raise CheckpointError(
            f"{where}: metadata {METADATA_KEYS['observation_kind']} is {kind!r}, expected one "
            f"of {sorted(LAYOUTS)}"
        )
    layout = parsed("observation_layout")
    dim = props[METADATA_KEYS["obs_dim"]]
    if layout != list(LAYOUTS[kind]) or dim != str(len(LAYOUTS[kind])):
        raise CheckpointError(
            f"{where}: metadata says the {kind!r} observation but gives layout {layout} "
            f"(dim {dim}); that kind is {list(LAYOUTS[kind])} (dim {len(LAYOUTS[kind])})"
        )
    description = parsed("actions")
    try:
        if not isinstance(description, dict):
            raise ConfigError(f"expected a JSON object, got {description!r}")
        actions = ActionSet.from_dict(description)
    except ConfigError as err:
        raise CheckpointError(f"{where}: metadata {METADATA_KEYS['actions']}: {err}") from err
    source = parsed("source")
    return {
        "format_version": ONNX_FORMAT_VERSION,
        "method": props[METADATA_KEYS["method"]],
        "observation": {"kind": kind, "layout": layout, "dim": len(layout)},
        "actions": actions,
        "source": source if isinstance(source, dict) else {},
    }


class OnnxGreedyPolicy:
    """argmax_a Q(s, a) of an onnxruntime session over an exported policy.

    ``__call__(obs)``: one observation (obs_dim,) -> the action index (int).
    ``q_values(obs)``: (B, obs_dim) -> (B, n_actions) float32 Q-values.
    """

    def __init__(self, session: Any, obs_dim: int, n_actions: int) -> None:
        self._session = session
        self.obs_dim = int(obs_dim)
        self.n_actions = int(n_actions)
        self._input = np.empty((1, self.obs_dim), dtype=np.float32)
        self._outputs = [OUTPUT_NAME]

    def __call__(self, obs: np.ndarray) -> int:
        self._input[0] = obs  # raises on a wrong shape; casts to float32
        q = self._session.run(self._outputs, {INPUT_NAME: self._input})[0]
        return int(q[0].argmax())

    def q_values(self, obs: np.ndarray) -> np.ndarray:
        batch = np.ascontiguousarray(obs, dtype=np.float32)
        if batch.ndim != 2 or batch.shape[1] != self.obs_dim:
            raise ValueError(
                f"q_values: expected (B, {self.obs_dim}) observations, got {batch.shape}"
            )
        return np.asarray(self._session.run(self._outputs, {INPUT_NAME: batch})[0])


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
    session = _session(read_model_bytes(path), str(path))
    meta = read_metadata(session.get_modelmeta().custom_metadata_map, str(path))
    _check_signature(session, meta["observation"]["dim"], meta["actions"].size, str(path))
    meta["file"] = str(path)
    return meta


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


def onnx_policy_from_bytes(
    data: bytes,
    where: str,
    *,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] = ("paper", "the caller"),
) -> tuple[OnnxGreedyPolicy, ActionSet, dict[str, Any]]:
    """``load_onnx_policy`` of a model already in memory (``where`` names it in messages)."""
    session = _session(data, where)
    meta = read_metadata(session.get_modelmeta().custom_metadata_map, where)
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
    _check_signature(session, have["dim"], actions.size, where)
    policy = OnnxGreedyPolicy(session, have["dim"], actions.size)
    probe = policy.q_values(np.zeros((1, have["dim"]), dtype=np.float32))
    if probe.shape != (1, actions.size) or not np.all(np.isfinite(probe)):
        raise CheckpointError(
            f"{where}: the graph returns {probe.shape} values for one observation "
            f"({'finite' if np.all(np.isfinite(probe)) else 'NaN or inf'}); its metadata "
            f"promises (1, {actions.size}) finite Q-values"
        )
    meta["file"] = where
    return policy, actions, meta


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
        reason = " ".join(str(err).split())[:_ONE_LINE]
        raise CheckpointError(
            f"{where}: not an ONNX model onnxruntime can load ({type(err).__name__}: {reason})"
        ) from err


def _check_signature(session: Any, obs_dim: int, n_actions: int, where: str) -> None:
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
