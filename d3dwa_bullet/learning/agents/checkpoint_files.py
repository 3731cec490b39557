"""The files of a checkpoint directory: their names, which agent holds which, and their
digests (size and SHA-256, recorded in meta.json). ``checkpoint`` describes the layout."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

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
NUMPY_WEIGHTS_FILE = "weights.npz"
"""D3QN: the tensors of ``weights.pt`` as numpy arrays, read without torch (``numpy_policy``); not in
meta.json (it is made beside a finished checkpoint) but tied to it by the SHA-256 of weights.pt it holds."""
DATA_FILES = {"d3qn": WEIGHTS_FILE, "dqdwa": TABLE_FILE}
#: Files a checkpoint may carry besides the policy (see module docstring).
EXTRA_FILES = frozenset(
    {CONFIG_FILE, CURVE_FILE, SUMMARY_FILE, TRAINING_STATE_FILE, TRAINING_TENSORS_FILE, REPLAY_FILE}
)
CHECKPOINT_FILES = {META_FILE, WEIGHTS_FILE, TABLE_FILE, NUMPY_WEIGHTS_FILE} | EXTRA_FILES


def digest(path: Path) -> dict[str, Any]:
    """Size (bytes) and SHA-256 of a file, as meta.json records them."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return {"bytes": path.stat().st_size, "sha256": h.hexdigest()}


def fsync(path: Path) -> None:
    """Flush a written file to disk."""
    with open(path, "rb") as f:
        os.fsync(f.fileno())
