"""Train D3DWA with domain randomisation (the shipped ``d3dwa-dr`` policy).

    python scripts/train_randomized.py                       # configs/d3dwa-dr.yaml -> runs/d3dwa-dr
    python scripts/train_randomized.py --out runs/dr2 --seed 1 --total-steps 50000
    python scripts/train_randomized.py --out runs/dr2 --resume
    python scripts/train_randomized.py --export policies/d3dwa-dr

Every episode draws a randomisation profile from the config's ``noise`` list (weights
``noise_probs``, e.g. none/paper/real) and samples that profile's distributions (slip,
lidar noise and dropout, odometry drift, gyro noise and bias, action latency, friction,
mass and motor limits) from the episode seed; worlds are the training worlds plus fresh
R-style layouts. Same options as ``d3dwa train``; this script only changes the defaults.
"""

from __future__ import annotations

import argparse
import sys

from d3dwa_bullet.cli.train import add_train_arguments, cmd_train
from d3dwa_bullet.errors import D3DWAError
from d3dwa_bullet.resources import configs_dir


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_train_arguments(ap)
    ap.set_defaults(config=str(configs_dir() / "d3dwa-dr.yaml"), out="runs/d3dwa-dr")
    args = ap.parse_args(argv)
    try:
        return cmd_train(args)
    except D3DWAError as err:
        print(f"train_randomized: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
