"""Is a learned method's choice the seeds' shared signal or each seed's noise? Mean-Q ensembles.

A diagnostic of issue 40 (beyond the paper; no method uses it). The five seeds of a shipped
D3QN method agree on the greedy action about as often as chance (noise.md#recipe-3), so each
seed's argmax may mostly be the noise of its own run. The mean of the seeds' Q-values keeps
what they share. This tool writes that mean as one ordinary D3QN checkpoint: the members'
networks side by side in a network k times as wide (the first layer stacked, the later ones
block-diagonal, each head averaged over the members), so its Q-values are the members' mean
to float32 rounding and every command that drives a policy (``run``, ``sweep``, ``compare``,
``drive``, ONNX export) drives it unchanged.

By default (leave one out) it writes, for each seed k of the folder, the ensemble
of the *other* seeds as ``<out>/seed-k``: five ensembles, each built without one training seed,
so that the ensemble has a distribution over training seeds to compare like any method's (its
members overlap, so its spread understates a fresh ensemble's). ``--all`` writes the one
ensemble of every seed as ``<out>/seed-0``.

    python -m tools.experiments.seed_ensemble policies/d3dwa-dr --out runs/ensemble/d3dwa-dr
    d3dwa sweep --axes '' --recovery nav2 --profiles none,real,harsh --methods d3dwa-dr \
      --policy runs/ensemble/d3dwa-dr --layouts 10 --seeds 1 --out runs/ensemble-nav2
"""

from __future__ import annotations

import dataclasses
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import torch

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.evaluation.policy_runs import check_one_experiment
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.learning.agents.checkpoint_save import save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.seed_dirs import seed_dirs
from tools.entry import ToolParser, tool_main


def _linears(network: DuelingQNetwork) -> list[torch.nn.Linear]:
    return [m for m in network.body if isinstance(m, torch.nn.Linear)]


def mean_network(networks: Sequence[DuelingQNetwork]) -> DuelingQNetwork:
    """One DuelingQNetwork whose Q-values are the mean of ``networks``' (same sizes each).

    Q_i = V_i + A_i - mean(A_i), so the mean over i is (mean V_i) + (mean A_i) - mean(mean A_i):
    a dueling network whose value and advantage heads average the members' over their
    side-by-side features."""
    first, k = networks[0], len(networks)
    if any((n.obs_dim, n.n_actions, n.hidden) != (first.obs_dim, first.n_actions, first.hidden)
           for n in networks):  # fmt: skip
        raise CheckpointError("the members' Q-networks differ in size; they cannot be averaged")
    wide = DuelingQNetwork(first.obs_dim, first.n_actions, [h * k for h in first.hidden])
    member_layers = [_linears(net) for net in networks]
    with torch.no_grad():
        for depth, (layer, *sources) in enumerate(zip(_linears(wide), *member_layers, strict=True)):
            layer.weight.zero_()
            for i, src in enumerate(sources):
                rows = slice(i * src.out_features, (i + 1) * src.out_features)
                cols = (
                    slice(None)
                    if depth == 0
                    else slice(i * src.in_features, (i + 1) * src.in_features)
                )
                layer.weight[rows, cols] = src.weight
                layer.bias[rows] = src.bias
        for head in ("value", "advantage"):
            out = getattr(wide, head)
            width = getattr(first, head).in_features
            for i, net in enumerate(networks):
                out.weight[:, i * width : (i + 1) * width] = getattr(net, head).weight / k
            out.bias.copy_(sum(getattr(net, head).bias for net in networks) / k)
    return wide


def write_ensemble(members: dict[int, Path], out: Path) -> Path:
    """The mean-Q checkpoint of the member seed folders, written to ``out`` (atomically)."""
    loaded = [load_checkpoint(path) for path in members.values()]
    agents = [agent for agent, _ in loaded if isinstance(agent, D3QNAgent)]
    if len(agents) != len(loaded):
        raise CheckpointError(
            f"{next(iter(members.values())).parent}: not a D3QN policy; only D3QN policies have "
            "Q-networks to average"
        )
    first = agents[0]
    wide = mean_network([a.online for a in agents])
    config = dataclasses.replace(first.config, hidden=wide.hidden)
    ensemble = D3QNAgent(first.actions, config, first.obs_layout)
    ensemble.online.load_state_dict(wide.state_dict())
    ensemble.env_steps, ensemble.train_steps = first.env_steps, first.train_steps
    meta = loaded[0][1]
    # the training terms every member records alike; not one member's validation or run name
    shared = [m.get("metadata") or {} for _, m in loaded]
    metadata = {k: v for k, v in shared[0].items() if all(s.get(k) == v for s in shared)}
    metadata["ensemble_of"] = {f"seed-{k}": str(path) for k, path in members.items()}
    config_path = next(iter(members.values())) / "config.json"
    run_config = load_json(config_path, CheckpointError, "training config.json")
    if not isinstance(run_config, dict) or not isinstance(run_config.get("agent"), dict):
        raise CheckpointError(f"{config_path}: expected a training config with an 'agent' block")
    run_config["agent"]["hidden"] = list(wide.hidden)
    with tempfile.TemporaryDirectory() as tmp:
        config_file = Path(tmp) / "config.json"
        config_file.write_text(json.dumps(run_config, indent=2) + "\n", encoding="utf-8")
        return save_checkpoint(out, ensemble, metadata, method=str(meta["method"]),
                               extra_files={"config.json": config_file})  # fmt: skip


def write_ensembles(folder: Path, out: Path, leave_one_out: bool = True) -> dict[int, Path]:
    """The ensembles of ``folder``'s seeds (module docstring), as out/seed-k."""
    if not folder.is_dir():
        raise CheckpointError(f"{folder}: no such policy folder")
    seeds = seed_dirs(folder)
    if len(seeds) < 2 + leave_one_out:
        raise CheckpointError(f"{folder}: needs {2 + leave_one_out} or more seed folders")
    check_one_experiment(folder, seeds)
    if not leave_one_out:
        return {0: write_ensemble(seeds, out / "seed-0")}
    return {k: write_ensemble({j: p for j, p in seeds.items() if j != k}, out / f"seed-{k}")
            for k in seeds}  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="seed_ensemble", description=__doc__.split("\n")[0])
    parser.add_argument("policy", type=Path, help="a policy folder with seed-<k> folders")
    parser.add_argument("--out", type=Path, required=True, help="where the ensembles go")
    parser.add_argument("--all", action="store_true",
                        help="one ensemble of every seed (default: leave one out)")  # fmt: skip
    args = parser.parse_args(argv)
    for k, path in write_ensembles(args.policy, args.out, not args.all).items():
        print(f"seed-{k}: {path}", file=sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
