"""Train the example DQN on the registered env for a few thousand steps and save the zip.

    python -m sb3_dqn.train --steps 4000   (needs stable-baselines3: pip install ".[train]")

The env is made with the terms ``chooser.SB3DQN`` declares, so the zip and its declaration
agree; ``run`` is what a test calls with a tiny budget.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium
from stable_baselines3 import DQN

from d3dwa_bullet import ENV_ID
from sb3_dqn.chooser import MODEL, SB3DQN


def run(steps: int = 4000, seed: int = 0, out: Path = MODEL) -> Path:
    """Train for ``steps`` env steps from ``seed``; returns the zip written."""
    env = gymnasium.make(
        ENV_ID, weights_only=len(SB3DQN.actions) == 25, decision_steps=SB3DQN.hold,
        observation=SB3DQN.observation,
    )  # fmt: skip
    model = DQN(
        "MlpPolicy", env, seed=seed, learning_starts=min(500, steps // 4), buffer_size=20_000,
        train_freq=4, target_update_interval=500, exploration_fraction=0.5, device="cpu",
    )  # fmt: skip
    model.learn(total_timesteps=steps)
    model.save(out)
    env.close()
    return Path(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=MODEL)
    args = ap.parse_args()
    print(run(args.steps, args.seed, args.out))


if __name__ == "__main__":
    main()
