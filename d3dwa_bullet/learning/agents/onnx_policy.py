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

This module imports numpy, the pure planning layer and ``policy_terms`` only, never torch;
onnx and onnxruntime are imported when a file is loaded (the optional ``robot`` extra). The
greedy action is the argmax of the Q-values (the lowest index on an exact tie, as numpy's
argmax); it agrees with the torch and numpy policies except where two Q-values tie to within
float32 rounding.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.onnx_graph import GraphCost, check_graph
from d3dwa_bullet.learning.agents.policy_terms import (
    DEFAULT_DECISION_STEPS,
    DEFAULT_RECOVERY,
    decision_period,
    trained_recovery,
)
from d3dwa_bullet.limits import MAX_POLICY_BYTES
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.progress import LAYOUTS, observation_layout

ONNX_FORMAT_VERSION = 2
"""Version of the metadata written here. Version 2 added the decision period and the recovery
layer: a runner from before them reads only version 1, so it refuses a new file in one line
instead of driving a held policy every step."""
READ_VERSIONS = (1, 2)
"""Versions this runner reads; in a version-1 file the OPTIONAL_FIELDS are absent."""
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
    "decision_steps": "d3dwa.decision_steps",  # decimal: control steps each action is held
    "recovery": "d3dwa.recovery",  # the recovery layer it trained inside: none | nav2
}
"""Field -> metadata_props key of an exported policy."""
OPTIONAL_FIELDS = {"decision_steps": str(DEFAULT_DECISION_STEPS), "recovery": DEFAULT_RECOVERY}
"""Fields version-1 exports lack -> the value their absence means (the paper's agent); a
version-2 file must hold them."""
INSTALL_HINT = "pip install 'd3dwa-bullet[robot]'"
PROBE_OBSERVATIONS = 64
"""Sampled observations (and the all-zero one) a file's Q-values must be finite on to load."""
SIGNED_ENTRIES = frozenset({"theta_goal", "v", "w"})
"""Observation entries in [-1, 1] (bearing, velocities); every other entry is in [0, 1]."""
_ONE_LINE = 300  # characters of a library's own message kept in ours


def sample_observations(layout: Sequence[str], n: int, seed: int) -> np.ndarray:
    """(n, len(layout)) float32 observations in their entries' ranges (SIGNED_ENTRIES in
    [-1, 1], the rest in [0, 1]), uniform, from ``seed``: what a check or a benchmark feeds."""
    rng = np.random.default_rng(seed)
    low = np.array([-1.0 if name in SIGNED_ENTRIES else 0.0 for name in layout])
    return rng.uniform(low, 1.0, (n, len(layout))).astype(np.float32)


def metadata_props(
    method: str,
    kind: str,
    actions: ActionSet,
    source: Mapping[str, Any],
    decision_steps: int = DEFAULT_DECISION_STEPS,
    recovery: str = DEFAULT_RECOVERY,
) -> dict[str, str]:
    """The metadata_props of a policy for ``method`` reading observation ``kind``, trained
    with ``decision_steps`` inside ``recovery`` (the exporter's half of the description
    ``read_metadata`` checks)."""
    layout = observation_layout(kind)
    return {
        METADATA_KEYS["format_version"]: str(ONNX_FORMAT_VERSION),
        METADATA_KEYS["method"]: method,
        METADATA_KEYS["observation_kind"]: kind,
        METADATA_KEYS["observation_layout"]: json.dumps(list(layout)),
        METADATA_KEYS["obs_dim"]: str(len(layout)),
        METADATA_KEYS["actions"]: json.dumps(actions.to_dict(), sort_keys=True),
        METADATA_KEYS["source"]: json.dumps(dict(source), sort_keys=True, allow_nan=False),
        METADATA_KEYS["decision_steps"]: str(decision_steps),
        METADATA_KEYS["recovery"]: recovery,
    }


def read_metadata(props: Mapping[str, str], where: str) -> dict[str, Any]:
    """Parse and check metadata_props: {format_version, method, observation: {kind, layout,
    dim}, actions: ActionSet, source, decision_steps: int, recovery: str} (the last two
    OPTIONAL_FIELDS). CheckpointError naming ``where``, the key and a bad value."""
    version_key = METADATA_KEYS["format_version"]
    if version_key not in props:
        ours = sorted(k for k in props if k.startswith("d3dwa."))
        raise CheckpointError(
            f"{where}: not a d3dwa policy: its metadata has no {version_key!r}"
            + (f" (only {ours})" if ours else "")
            + "; export one with `d3dwa export --onnx DIR`"
        )
    versions = {str(v): v for v in READ_VERSIONS}
    if props[version_key] not in versions:
        raise CheckpointError(
            f"{where}: metadata {version_key} is {props[version_key]!r}, this code reads "
            f"versions {', '.join(versions)}"
        )
    version = versions[props[version_key]]
    optional = OPTIONAL_FIELDS if version == 1 else {}
    missing = [v for k, v in METADATA_KEYS.items() if k not in optional and v not in props]
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
    steps_key, recovery_key = METADATA_KEYS["decision_steps"], METADATA_KEYS["recovery"]
    steps = props.get(steps_key, OPTIONAL_FIELDS["decision_steps"])
    recovery = props.get(recovery_key, OPTIONAL_FIELDS["recovery"])
    return {
        "format_version": version,
        "method": props[METADATA_KEYS["method"]],
        "observation": {"kind": kind, "layout": layout, "dim": len(layout)},
        "actions": actions,
        "source": source if isinstance(source, dict) else {},
        "decision_steps": decision_period(steps, f"{where}: metadata {steps_key}"),
        "recovery": trained_recovery(recovery, f"{where}: metadata {recovery_key}"),
    }


class OnnxGreedyPolicy:
    """argmax_a Q(s, a) of an onnxruntime session over an exported policy.

    ``__call__(obs)``: one observation (obs_dim,) -> the action index (int).
    ``q_values(obs)``: (B, obs_dim) -> (B, n_actions) float32 Q-values, run in batches of
    ``cost.rows_per_run()`` so that no run holds more than the graph check allows.
    Either raises CheckpointError (naming ``where``) if the runtime fails or the Q-values
    are not (B, n_actions) finite numbers.
    """

    def __init__(
        self, session: Any, obs_dim: int, n_actions: int, where: str, cost: GraphCost
    ) -> None:
        self._session = session
        self.obs_dim = int(obs_dim)
        self.n_actions = int(n_actions)
        self.where = where
        self._rows = cost.rows_per_run()
        self._input = np.empty((1, self.obs_dim), dtype=np.float32)
        self._outputs = [OUTPUT_NAME]

    def __call__(self, obs: np.ndarray) -> int:
        self._input[0] = obs  # raises on a wrong shape; casts to float32
        return int(self._run(self._input)[0].argmax())

    def q_values(self, obs: np.ndarray) -> np.ndarray:
        batch = np.ascontiguousarray(obs, dtype=np.float32)
        if batch.ndim != 2 or batch.shape[1] != self.obs_dim:
            raise ValueError(
                f"q_values: expected (B, {self.obs_dim}) observations, got {batch.shape}"
            )
        if len(batch) <= self._rows:
            return self._run(batch)
        rows = self._rows
        return np.concatenate([self._run(batch[i : i + rows]) for i in range(0, len(batch), rows)])

    def _run(self, batch: np.ndarray) -> np.ndarray:
        try:
            q = np.asarray(self._session.run(self._outputs, {INPUT_NAME: batch})[0])
        except Exception as err:  # onnxruntime raises its own types (Fail, RuntimeException)
            reason = " ".join(str(err).split())[:_ONE_LINE]
            raise CheckpointError(
                f"{self.where}: the policy failed to run on {len(batch)} observation(s) "
                f"({type(err).__name__}: {reason})"
            ) from err
        if q.shape != (len(batch), self.n_actions) or q.dtype != np.float32:
            raise CheckpointError(
                f"{self.where}: the policy returned {q.dtype} {q.shape} for {len(batch)} "
                f"observation(s), not float32 ({len(batch)}, {self.n_actions}) Q-values"
            )
        finite = np.isfinite(q).all(axis=1)
        if not finite.all():
            row = int(np.flatnonzero(~finite)[0])
            shown = np.array2string(batch[row], precision=3, max_line_width=10**6)
            raise CheckpointError(
                f"{self.where}: the policy's Q-values are NaN or inf for observation {shown}; "
                "refusing to choose an action from them"
            )
        return q


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
    meta, _, session = _checked_session(read_model_bytes(path), str(path))
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
    meta, cost, session = _checked_session(data, where)
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
    policy = OnnxGreedyPolicy(session, have["dim"], actions.size, where, cost)
    probe = sample_observations(have["layout"], PROBE_OBSERVATIONS, seed=0)
    policy.q_values(np.vstack([np.zeros((1, have["dim"]), dtype=np.float32), probe]))
    meta["file"] = where
    return policy, actions, meta


def _checked_session(data: bytes, where: str) -> tuple[dict[str, Any], GraphCost, Any]:
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
        reason = " ".join(str(err).split())[:_ONE_LINE]
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
