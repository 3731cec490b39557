"""A D3QN's greedy policy in numpy, and the numpy copy of its weights that runs it without torch.

A D3QN's greedy action is argmax_a Q(s, a) = argmax_a A(s, a), because V(s) and the mean
advantage are the same for every action; the policy therefore evaluates only the shared
MLP and the advantage head, as float32 numpy matmuls into preallocated buffers (a single
12-d observation through torch costs several times more in call overhead than in maths).

Loading ``weights.pt`` needs torch, whose import costs seconds a process (docs/design/episode-cost.md).
``weights.npz`` beside it holds the same float32 tensors under the same names, and the SHA-256 of
the ``weights.pt`` they were copied from (``tools.policy_npz`` makes it for every shipped seed; a
test keeps the two equal). :func:`load_numpy_policy` checks meta.json as ``load_checkpoint`` does,
weights.pt's digest against meta.json, and that digest against the one the .npz holds, so a copy
that no longer matches its checkpoint is refused rather than run. Torch-free.
"""

from __future__ import annotations

import io
import os
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.io import atomic_write_bytes
from d3dwa_bullet.learning.agents.checkpoint_files import NUMPY_WEIGHTS_FILE, WEIGHTS_FILE
from d3dwa_bullet.learning.agents.checkpoint_meta import check_driven_as, check_file, read_meta
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import observation_layout

SOURCE_KEY = "source_sha256"
"""The .npz entry holding the SHA-256 (hex, a 0-d unicode array) of the weights.pt it copies."""

Layers = list[tuple[np.ndarray, np.ndarray]]
"""(weight (in, out) float32 C-contiguous, bias (out,) float32) of each linear layer in order."""


class DuelingGreedyPolicy:
    """argmax of the advantage stream of a dueling network, in numpy (a snapshot of its weights).

    layers: the shared MLP's linear layers then the advantage head (``Layers``); obs_dim: the
    observation's length. Like the ONNX runner, it never chooses from values that are not
    numbers: an advantage that comes out NaN or inf is a CheckpointError naming ``where``
    (the checkpoint) and the observation."""

    def __init__(self, layers: Layers, obs_dim: int, where: str = "the policy") -> None:
        self.where = where
        self._layers = [
            (np.ascontiguousarray(w, dtype=np.float32), np.asarray(b, dtype=np.float32))
            for w, b in layers
        ]
        self._buffers = [np.empty(w.shape[1], dtype=np.float32) for w, _ in self._layers]
        self._input = np.empty(obs_dim, dtype=np.float32)
        self.obs_dim = obs_dim

    def __call__(self, obs: np.ndarray) -> int:
        x = self._input
        x[...] = obs  # raises on a wrong shape; casts to float32
        last = len(self._layers) - 1
        for i, ((w, b), out) in enumerate(zip(self._layers, self._buffers, strict=True)):
            np.dot(x, w, out=out)
            out += b
            if i < last:
                np.maximum(out, 0.0, out=out)
            x = out
        if not np.isfinite(x).all():
            shown = np.array2string(self._input, precision=3, max_line_width=10**6)
            raise CheckpointError(
                f"{self.where}: the policy's Q-values are NaN or inf for observation {shown}; "
                "refusing to choose an action from them"
            )
        return int(x.argmax())


def state_shapes(obs_dim: int, n_actions: int, hidden: Sequence[int]) -> dict[str, tuple[int, ...]]:
    """Tensor name -> shape of a ``DuelingQNetwork``'s state_dict of these sizes (torch's
    (out, in) weights): ``body.{2i}`` for the shared layers, then ``value`` and ``advantage``."""
    shapes: dict[str, tuple[int, ...]] = {}
    width = obs_dim
    for i, h in enumerate(hidden):
        shapes |= {f"body.{2 * i}.weight": (h, width), f"body.{2 * i}.bias": (h,)}
        width = h
    for head, out in (("value", 1), ("advantage", n_actions)):
        shapes |= {f"{head}.weight": (out, width), f"{head}.bias": (out,)}
    return shapes


def greedy_layers(state: Mapping[str, np.ndarray], hidden: Sequence[int]) -> Layers:
    """The policy's layers from a state_dict's arrays (torch's names and (out, in) weights)."""
    names = [f"body.{2 * i}" for i in range(len(hidden))] + ["advantage"]
    return [(np.asarray(state[f"{n}.weight"]).T, np.asarray(state[f"{n}.bias"])) for n in names]


def write_numpy_weights(
    directory: str | os.PathLike[str], state: Mapping[str, np.ndarray], source_sha256: str
) -> Path:
    """Write ``weights.npz`` into checkpoint ``directory`` (atomically): the state_dict's arrays
    under their names and ``source_sha256``, the SHA-256 of the weights.pt they came from."""
    if SOURCE_KEY in state:
        raise CheckpointError(f"{directory}: a tensor may not be named {SOURCE_KEY!r}")
    path = Path(directory) / NUMPY_WEIGHTS_FILE
    buffer = io.BytesIO()
    arrays = {k: np.asarray(v) for k, v in state.items()}
    np.savez(buffer, **arrays, **{SOURCE_KEY: np.array(source_sha256)})
    atomic_write_bytes(path, buffer.getvalue())
    return path


def write_beside_weights(
    directory: str | os.PathLike[str], state: Mapping[str, np.ndarray]
) -> Path:
    """``write_numpy_weights`` of a saved D3QN checkpoint's state_dict (as numpy arrays), tied to
    the SHA-256 its meta.json records for weights.pt (checked against the file first)."""
    root = Path(directory)
    meta = read_meta(root)
    check_file(root, WEIGHTS_FILE, meta)
    return write_numpy_weights(root, state, meta["files"][WEIGHTS_FILE]["sha256"])


def read_numpy_weights(path: Path) -> tuple[dict[str, np.ndarray], str]:
    """(arrays by name, the SHA-256 of their weights.pt) of a ``weights.npz``; CheckpointError
    (one line naming the file) if it cannot be read as a plain .npz of arrays."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"{path}: cannot be read as a .npz of arrays ({err})") from err
    source = arrays.pop(SOURCE_KEY, None)
    if source is None or source.shape != () or source.dtype.kind != "U":
        raise CheckpointError(
            f"{path}: holds no {SOURCE_KEY!r} entry (not made by tools.policy_npz?)"
        )
    return arrays, str(source)


def load_numpy_policy(
    path: str | os.PathLike[str],
    *,
    expected_actions: ActionSet | None = None,
    expected_observation: tuple[str, str] = ("paper", "the caller"),
) -> tuple[DuelingGreedyPolicy, ActionSet, dict[str, Any]] | None:
    """``policy.load_policy`` without torch for a D3QN checkpoint carrying ``weights.npz``:
    (policy, action set, meta), or None when the checkpoint has no .npz or is not a D3QN's
    (the caller then loads it with torch). CheckpointError as ``load_checkpoint`` raises it,
    and for a .npz whose recorded SHA-256 is not weights.pt's, or whose arrays are not the
    network meta.json describes (names, shapes, float32, finite)."""
    root = Path(path)
    npz = root / NUMPY_WEIGHTS_FILE
    if not npz.is_file():
        return None
    meta = read_meta(root)
    if meta["agent"] != "d3qn":
        return None
    folder_terms(root)
    kind, reader = expected_observation
    layout, actions = check_driven_as(
        root, meta, expected_actions, observation_layout(kind), reader
    )
    weights = check_file(root, WEIGHTS_FILE, meta)
    arrays, source = read_numpy_weights(npz)
    if source != meta["files"][WEIGHTS_FILE]["sha256"]:
        raise CheckpointError(
            f"{npz}: copies a weights.pt of another SHA-256 than {weights}'s; remake it with "
            f"`python -m tools.policy_npz {root}` or delete it"
        )
    config = meta["config"]
    hidden = config.get("hidden") if isinstance(config, Mapping) else None
    if not isinstance(hidden, list) or not all(isinstance(h, int) and h > 0 for h in hidden):
        raise CheckpointError(f"{root / 'meta.json'}: field 'config': hidden is {hidden!r}")
    want = state_shapes(len(layout), actions.size, hidden)
    if sorted(arrays) != sorted(want):
        raise CheckpointError(f"{npz}: array names {sorted(arrays)} differ from {sorted(want)}")
    for name, shape in want.items():
        got = arrays[name]
        if got.shape != shape or got.dtype != np.float32:
            raise CheckpointError(
                f"{npz}: array {name!r} is {got.shape} {got.dtype}, meta.json needs {shape} float32"
            )
        if not np.isfinite(got).all():
            raise CheckpointError(f"{npz}: array {name!r} holds NaN or inf")
    policy = DuelingGreedyPolicy(greedy_layers(arrays, hidden), len(layout), str(path))
    return policy, actions, meta
