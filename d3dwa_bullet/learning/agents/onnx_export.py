"""A trained D3QN policy -> one ONNX file of its Q-values, for robots without torch (SPEC section 10).

The graph (input ``obs`` (B, obs_dim) float32 -> output ``q`` (B, |A|) float32, B free) and
its metadata are described in ``onnx_policy``, which runs it.

How the graph is built: directly with ``onnx.helper`` from the checkpoint's weights, not with
``torch.onnx.export``. torch 2.13's exporter defaults to its torch.export (dynamo) path,
which needs the onnxscript package (no dependency of ours), and its TorchScript path
(``dynamo=False``) is deprecated. The network is small and fixed (``DuelingQNetwork``): one
Gemm + Relu per hidden layer, one Gemm per stream, then ReduceMean, Add and Sub in the order
``forward`` adds them ((V + A) - mean A). Built directly, each initializer is named after the
state_dict entry it holds, the same weights always give the same bytes, and the model asks
for opset 17 with the lowest IR version that carries it, so any onnxruntime from 1.12 on
(the ``robot`` extra asks for >= 1.18) reads it.

Every export is checked before a byte is written: ``onnx.checker`` (with shape inference),
then the runner loads it from memory exactly as a robot would (so an export must pass the
runner's own graph check, ``onnx_graph``: its operator allowlist is what this module emits), and its Q-values on
``CHECK_OBSERVATIONS`` sampled observations must match the torch network's within
``Q_TOLERANCE`` (relative to the largest |Q|), with the same greedy action wherever torch's
best two actions are further apart than that. Only then is the file written, atomically
(``d3dwa_bullet.io``): an interrupted or refused export leaves no file, or the old one.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import CheckpointError, InstallError
from d3dwa_bullet.io import atomic_write_bytes
from d3dwa_bullet.learning.agents.checkpoint import (
    META_FILE,
    WEIGHTS_FILE,
    load_checkpoint,
    read_meta,
)
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.learning.agents.onnx_graph import OPSET
from d3dwa_bullet.learning.agents.onnx_policy import (
    INPUT_NAME,
    INSTALL_HINT,
    OUTPUT_NAME,
    OnnxGreedyPolicy,
    metadata_props,
    onnx_policy_from_bytes,
    sample_observations,
)
from d3dwa_bullet.learning.agents.policy_terms import checkpoint_terms
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import kind_of_layout, observation_layout
from d3dwa_bullet.resources import policies_dir

CHECK_OBSERVATIONS = 1_000
"""Sampled observations every export is checked on (a few milliseconds)."""
Q_TOLERANCE = 2e-6
"""Largest |Q_onnx - Q_torch| an export may show, relative to max(1, max |Q|): about 16
float32 roundings of the largest Q-value. The same sums in another order (onnxruntime's
Gemm against torch's) differ by 2-5e-7 of it on the shipped policies; torch alone, batch of
one against batch of many, differs by as much. An absolute bound would not do: shipped
Q-values reach 130, where one float32 step is 1.5e-5."""


@dataclass(frozen=True)
class ExportResult:
    """What ``export_onnx`` wrote and what its check measured."""

    file: Path
    method: str
    observation: str
    """Observation kind the policy reads (paper, progress)."""
    n_actions: int
    bytes: int
    max_abs_dq: float
    """max |Q_onnx - Q_torch| over the checked observations and actions."""
    max_abs_q: float
    """max |Q_torch| over the same: the scale float32 rounding is relative to."""
    agreement: float
    """Fraction of the checked observations on which both pick the same greedy action."""
    checked: int
    """Number of observations checked."""


def q_values(network: DuelingQNetwork, obs: np.ndarray) -> np.ndarray:
    """Torch's Q-values of a batch: (B, obs_dim) -> (B, n_actions) float32."""
    with torch.no_grad():
        return network(torch.as_tensor(obs, dtype=torch.float32)).numpy()


def onnx_model(network: DuelingQNetwork, props: dict[str, str]) -> Any:
    """The ``onnx.ModelProto`` of a network's Q-values, with ``props`` as its metadata_props."""
    onnx = _onnx("onnx_model")
    helper, numpy_helper = onnx.helper, onnx.numpy_helper
    initializers: list[Any] = []
    nodes: list[Any] = []

    def gemm(x: str, linear: nn.Linear, key: str, out: str) -> str:
        for part in ("weight", "bias"):
            value = getattr(linear, part).detach().cpu().numpy().astype(np.float32)
            initializers.append(numpy_helper.from_array(value, f"{key}.{part}"))
        # y = x W^T + b, with W stored (out, in) as torch keeps it
        nodes.append(helper.make_node("Gemm", [x, f"{key}.weight", f"{key}.bias"], [out], transB=1))
        return out

    features = INPUT_NAME
    for name, module in network.body.named_children():
        if isinstance(module, nn.Linear):
            pre = gemm(features, module, f"body.{name}", f"body.{name}.out")
            features = f"body.{name}.relu"
            nodes.append(helper.make_node("Relu", [pre], [features]))
    value = gemm(features, network.value, "value", "value")
    advantage = gemm(features, network.advantage, "advantage", "advantage")
    nodes += [
        helper.make_node("ReduceMean", [advantage], ["advantage_mean"], axes=[1], keepdims=1),
        helper.make_node("Add", [value, advantage], ["value_plus_advantage"]),
        helper.make_node("Sub", ["value_plus_advantage", "advantage_mean"], [OUTPUT_NAME]),
    ]
    graph = helper.make_graph(
        nodes,
        "dueling_q",
        [helper.make_tensor_value_info(INPUT_NAME, onnx.TensorProto.FLOAT, ["batch", network.obs_dim])],
        [helper.make_tensor_value_info(OUTPUT_NAME, onnx.TensorProto.FLOAT, ["batch", network.n_actions])],
        initializers,
    )  # fmt: skip
    opset = [helper.make_opsetid("", OPSET)]
    model = helper.make_model(
        graph,
        opset_imports=opset,
        ir_version=helper.find_min_ir_version_for(opset),
        producer_name="d3dwa-bullet",
        producer_version=__version__,
        doc_string=(
            f"Q-values of a dueling Q-network (V + A - mean A): {INPUT_NAME} (batch, "
            f"{network.obs_dim}) float32 -> {OUTPUT_NAME} (batch, {network.n_actions}) float32; "
            "greedy action = argmax. Metadata d3dwa.* describes observation and actions."
        ),
    )
    helper.set_model_props(model, props)
    try:
        onnx.checker.check_model(model, full_check=True)
    except onnx.checker.ValidationError as err:  # pragma: no cover - a bug here, not user input
        raise CheckpointError(f"the exported graph fails onnx.checker: {err}") from err
    return model


def export_onnx(
    policy_dir: str | os.PathLike[str],
    out_file: str | os.PathLike[str],
    *,
    method: str | None = None,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] | None = None,
) -> ExportResult:
    """Export the D3QN checkpoint ``policy_dir`` (as ``load_policy`` reads) to ``out_file``.

    method: the method recorded in the file (default: the checkpoint's own). expected_actions
    and expected_observation ((kind, who feeds it)) are checked as ``load_policy`` checks
    them; without the latter the checkpoint must read one of the known observation kinds.
    The file records the checkpoint's decision period and the recovery layer it trained
    inside (``policy_terms``), so a runner drives it as ``make_controller`` drives the
    checkpoint. The export is checked (module docstring) before it is written; the parent
    directory is created. CheckpointError (one line) for a tabular (dqdwa) policy, a
    directory that is not a checkpoint, a bad decision period or recovery in its meta.json,
    an ``out_file`` that is a directory, or a failed check.
    """
    root, out = Path(policy_dir), Path(out_file)
    _onnx(str(root))  # the extra is there before any work is done
    if out.is_dir():
        raise CheckpointError(f"{out}: is a directory; give the .onnx file to write")
    check_exportable(root)
    kind, reader = expected_observation or (None, "the caller")
    agent, meta = load_checkpoint(
        root,
        expected_actions=expected_actions,
        expected_layout=observation_layout(kind) if kind else None,
        reader=reader,
    )
    assert isinstance(agent, D3QNAgent)  # read_meta said d3qn
    kind = kind or kind_of_layout(agent.obs_layout)
    if kind is None:
        raise CheckpointError(
            f"{root}: observation layout {list(agent.obs_layout)} is none of the known kinds "
            "(paper, progress); no controller could feed it"
        )
    # the terms it is driven on travel with it: a runner holds each action as long
    decision_steps, recovery, scan_filter = checkpoint_terms(meta, str(root / META_FILE))
    method = method or str(meta["method"])
    network = agent.online.eval()
    props = metadata_props(
        method, kind, agent.actions, _source(root, meta), decision_steps, recovery, scan_filter
    )
    model = onnx_model(network, props)
    data = model.SerializeToString()
    policy, _, _ = onnx_policy_from_bytes(
        data, str(out), expected_actions=agent.actions, expected_observation=(kind, reader)
    )
    obs = sample_observations(agent.obs_layout, CHECK_OBSERVATIONS, seed=0)
    max_dq, agreement, max_q = _check(network, policy, obs, out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out, data)
    return ExportResult(
        out,
        method,
        kind,
        agent.actions.size,
        len(data),
        max_dq,
        max_q,
        agreement,
        CHECK_OBSERVATIONS,
    )


def check_exportable(policy_dir: str | os.PathLike[str]) -> None:
    """CheckpointError unless ``policy_dir`` holds a checkpoint (its meta.json, read
    without loading the weights) of a network: a tabular (dqdwa) one is refused."""
    meta = read_meta(policy_dir)
    if meta["agent"] != "d3qn":
        raise CheckpointError(
            f"{policy_dir}: a tabular policy ({meta['method']}) is a Q-table over a "
            "discretised state, not a network; only D3QN policies export to ONNX"
        )


def _check(
    network: DuelingQNetwork, policy: OnnxGreedyPolicy, obs: np.ndarray, out: Path
) -> tuple[float, float, float]:
    """(max |dQ|, action agreement, max |Q|) of the export on ``obs``; CheckpointError if the
    Q-values differ by more than the tolerance, or if the greedy actions differ where
    torch's values of the two choices are further apart than it."""
    q_torch, q_onnx = q_values(network, obs), policy.q_values(obs)
    dq = float(np.abs(q_onnx - q_torch).max())
    max_q = float(np.abs(q_torch).max())
    tolerance = Q_TOLERANCE * max(1.0, max_q)
    chosen = q_onnx.argmax(axis=1)
    same = chosen == q_torch.argmax(axis=1)
    regret = q_torch.max(axis=1) - q_torch[np.arange(len(obs)), chosen]
    if dq > tolerance or np.any(regret > tolerance):
        raise CheckpointError(
            f"{out}: not written: the exported graph's Q-values differ from torch's by up to "
            f"{dq:.3g} (tolerance {tolerance:.3g}) and pick another greedy action on "
            f"{int(np.sum(~same))} of {len(obs)} observations"
        )
    return dq, float(same.mean()), max_q


def _source(root: Path, meta: dict[str, Any]) -> dict[str, Any]:
    """The checkpoint fields worth keeping in the ONNX file (where it came from)."""
    extra = meta.get("metadata")
    extra = extra if isinstance(extra, dict) else {}
    weights = meta["files"].get(WEIGHTS_FILE, {})
    return {
        "checkpoint": _shown(root),
        "checkpoint_format_version": meta["format_version"],
        "method": meta["method"],
        "package_version": meta.get("package_version"),
        "exported_by": f"d3dwa-bullet {__version__}",
        "weights_sha256": weights.get("sha256"),
        "weights_bytes": weights.get("bytes"),
        "training_steps": meta["training_steps"],
        "env_steps": meta.get("env_steps"),
        "hidden": meta["config"].get("hidden"),
        "seed": meta["config"].get("seed"),
        "run": extra.get("run"),
        "selected": extra.get("selected"),
    }


def _shown(root: Path) -> str:
    """The checkpoint's path as the file records it: ``policies/<method>/seed-<k>`` for a
    shipped one (not where this machine installed it), else as given."""
    try:
        return f"policies/{root.resolve().relative_to(policies_dir().resolve()).as_posix()}"
    except (ValueError, InstallError):
        return str(root)


def _onnx(what: str) -> Any:
    try:
        # optional dependency: onnx is the `robot` extra, needed only to export
        import onnx
        import onnx.checker
        import onnx.helper
        import onnx.numpy_helper
    except ImportError as err:
        raise CheckpointError(
            f"{what}: cannot export to ONNX: the onnx package is not installed ({INSTALL_HINT})"
        ) from err
    return onnx
