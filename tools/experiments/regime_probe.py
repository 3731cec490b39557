"""Can the policy's observation tell the noise regime? A classifier on one step against a history.

Reads the per-step logs of a sweep directory: the 12-d observations (and chosen actions) of
every episode under two noise labels (default ``none`` and ``harsh``). Trains a small MLP to
tell the two apart (a) from a single observation, what the paper's memoryless policy sees, and
(b) from the last ``--history`` observations and actions stacked, what an RMA-style policy with
memory would see. Episodes are split by layout (the held-out layouts never train), the two
classes are balanced by subsampling, and held-out accuracy is printed per input with its
Wilson 95 % interval. 0.5 is chance.

    python -m tools.experiments.regime_probe runs/sources-sweep --history 10
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from d3dwa_bullet.errors import D3DWAError, ResultsError
from d3dwa_bullet.evaluation.jobs import row_log
from d3dwa_bullet.evaluation.results import job_rows
from d3dwa_bullet.evaluation.stats import wilson_interval
from tools.entry import ToolParser, fail, tool_main

EPOCHS = 60
HIDDEN = 64


def windows(log: dict[str, Any], history: int, stride: int) -> np.ndarray:
    """(N, history * 13): the last ``history`` observations each with its chosen horizon."""
    obs = np.asarray(log["observations"], dtype=np.float32)
    act = np.asarray(log["tau"], dtype=np.float32)[: len(obs), None] / 5.0
    step = np.concatenate([obs[: len(act)], act], axis=1)
    if len(step) < history:
        return np.zeros((0, history * step.shape[1]), dtype=np.float32)
    idx = np.arange(history - 1, len(step), stride)
    return np.stack([step[i - history + 1 : i + 1].ravel() for i in idx])


def dataset(sweep: Path, labels: Sequence[str], history: int, stride: int) -> dict[str, Any]:
    """Per layout: the windows of each class."""
    rows = [r for r in job_rows(sweep) if r["noise"] in labels]
    if not rows:
        raise ResultsError(f"{sweep}: no rows under {', '.join(labels)}")
    data: dict[str, list[list[np.ndarray]]] = {}
    for r in rows:
        log = row_log(sweep, r)
        cls = labels.index(r["noise"])
        data.setdefault(r["world"], [[], []])[cls].append(windows(log, history, stride))
    return {w: [np.concatenate(c) if c else None for c in per] for w, per in data.items()}


def accuracy(
    data: dict[str, Any], width: int, seed: int = 0, epochs: int = EPOCHS
) -> dict[str, float]:
    """Held-out accuracy of an MLP on the last ``width`` columns (13 per step) of the windows."""
    rng = np.random.default_rng(seed)
    layouts = sorted(w for w, per in data.items() if all(c is not None and len(c) for c in per))
    if len(layouts) < 2:
        raise ResultsError("need at least two layouts with episodes of both regimes")
    test = set(rng.permutation(layouts)[: len(layouts) // 2])

    def split(held: bool) -> tuple[torch.Tensor, torch.Tensor]:
        xs: list[list[np.ndarray]] = [[], []]
        for w in layouts:
            if (w in test) == held:
                for cls in (0, 1):
                    xs[cls].append(data[w][cls][:, -width:])
        a, b = np.concatenate(xs[0]), np.concatenate(xs[1])
        n = min(len(a), len(b))  # balanced: chance is 0.5
        a, b = a[rng.permutation(len(a))[:n]], b[rng.permutation(len(b))[:n]]
        x = torch.from_numpy(np.concatenate([a, b]))
        y = torch.cat([torch.zeros(n), torch.ones(n)])
        return x, y

    (xtr, ytr), (xte, yte) = split(False), split(True)
    torch.manual_seed(seed)
    net = torch.nn.Sequential(torch.nn.Linear(width, HIDDEN), torch.nn.ReLU(),
                              torch.nn.Linear(HIDDEN, 1))  # fmt: skip
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    loss_fn = torch.nn.BCEWithLogitsLoss()
    for _ in range(epochs):
        for batch in torch.randperm(len(xtr)).split(256):
            opt.zero_grad()
            loss_fn(net(xtr[batch]).squeeze(1), ytr[batch]).backward()
            opt.step()
    with torch.no_grad():
        hits = int(((net(xte).squeeze(1) > 0).float() == yte).sum())
    low, high = wilson_interval(hits, len(yte))
    return {"accuracy": hits / len(yte), "low": low, "high": high, "test": len(yte),
            "train": len(ytr)}  # fmt: skip


@tool_main
def main(argv: Sequence[str] | None = None) -> int:
    parser = ToolParser(prog="regime_probe", description=__doc__.split("\n")[0])
    parser.add_argument("sweep", type=Path)
    parser.add_argument("--labels", default="none,harsh", help="two noise labels of the rows")
    parser.add_argument("--history", type=int, default=10, help="steps in the long input")
    parser.add_argument("--stride", type=int, default=5, help="control steps between windows")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    labels = args.labels.split(",")
    if len(labels) != 2 or not 2 <= args.history <= 100 or not 1 <= args.stride <= 100:
        fail("regime_probe", "--labels takes two labels, --history 2-100, --stride 1-100")
    torch.set_num_threads(1)
    try:
        data = dataset(args.sweep, labels, args.history, args.stride)
        width = 13
        report = {"one step": accuracy(data, width),
                  f"{args.history} steps": accuracy(data, width * args.history)}  # fmt: skip
    except D3DWAError as exc:
        fail("regime_probe", str(exc))
    if args.json:
        print(json.dumps(report, indent=1))
    else:
        for name, r in report.items():
            print(f"{name}: held-out accuracy {100 * r['accuracy']:.1f} % "
                  f"[{100 * r['low']:.1f}, {100 * r['high']:.1f}] on {r['test']} windows")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
