"""Write ``weights.npz`` beside each D3QN checkpoint's ``weights.pt``: the same float32 tensors
under the same names, and weights.pt's SHA-256, so evaluation runs the policy without importing
torch (``d3dwa_bullet.learning.agents.numpy_policy``; docs/design/episode-cost.md)::

    python -m tools.policy_npz                      # every shipped seed under policies/
    python -m tools.policy_npz runs/my-policy       # one checkpoint directory

The checkpoint is loaded and checked by ``load_checkpoint`` first (torch), and the .npz is read
back and compared array by array before the tool reports it. A tabular (DQDWA) checkpoint needs
none and is skipped; a directory that is not a checkpoint stops the run with one line.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.checkpoint import WEIGHTS_FILE, load_checkpoint, read_meta
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.numpy_policy import read_numpy_weights, write_beside_weights
from d3dwa_bullet.resources import policies_dir
from tools.entry import ToolParser, tool_main


def shipped_checkpoints() -> list[Path]:
    """Every shipped checkpoint directory (policies/<method>/seed-<n>/), sorted."""
    return sorted(p.parent for p in policies_dir().glob("*/seed-*/meta.json"))


def write_one(directory: Path) -> str:
    """Write the .npz of one checkpoint; a line saying what was done."""
    agent, meta = load_checkpoint(directory, expected_layout=None)
    if not isinstance(agent, D3QNAgent):
        return f"{directory}: {meta['agent']} checkpoint, no weights.pt: skipped"
    state = {k: v.detach().cpu().numpy() for k, v in agent.state_dict().items()}
    sha = read_meta(directory)["files"][WEIGHTS_FILE]["sha256"]
    path = write_beside_weights(directory, state)
    back, source = read_numpy_weights(path)
    if source != sha or sorted(back) != sorted(state):
        raise CheckpointError(f"{path}: read back with other names or digest than written")
    for key, value in state.items():
        if back[key].dtype != value.dtype or not np.array_equal(back[key], value):
            raise CheckpointError(f"{path}: array {key!r} read back differs from weights.pt")
    return f"{path}: {len(state)} arrays of weights.pt {sha[:12]}"


@tool_main
def main(argv: Sequence[str] | None = None) -> None:
    ap = ToolParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="*", type=Path, help="checkpoint directories (default: shipped)")
    args = ap.parse_args(argv)
    for directory in args.dirs or shipped_checkpoints():
        print(write_one(directory), flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
