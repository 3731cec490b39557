"""The dueling Q-network (paper Eq. dueling): a shared MLP feeding a value and an advantage stream."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import torch
from torch import nn

from d3dwa_bullet.errors import CheckpointError, ConfigError


def parameter_count(obs_dim: int, n_actions: int, hidden: Sequence[int]) -> int:
    """Weights and biases of a DuelingQNetwork of these sizes, counted without building it (a
    checkpoint's meta.json is checked against its weights file before any allocation)."""
    widths = [int(obs_dim), *(int(h) for h in hidden)]
    body = sum((a + 1) * b for a, b in zip(widths, widths[1:], strict=False))
    return body + (widths[-1] + 1) * (1 + int(n_actions))


def check_network_fits(
    meta_path: Path, data: Path, obs_dim: int, n_actions: int, hidden: Sequence[int]
) -> None:
    """CheckpointError when the network meta.json describes holds more float32 weights than
    the weights file has bytes: its size is checked before the network is allocated."""
    count = parameter_count(obs_dim, n_actions, hidden)
    size = data.stat().st_size
    if 4 * count > size:
        raise CheckpointError(
            f"{meta_path}: field 'config': hidden {list(hidden)} makes a network of {count:,} "
            f"weights ({4 * count / 2**20:,.1f} MiB as float32), but {data.name} holds only "
            f"{size:,} bytes"
        )


class DuelingQNetwork(nn.Module):
    """Q(s, a) = V(s) + A(s, a) - mean_a' A(s, a').

    obs_dim: length of the observation vector; n_actions: |A|; hidden: widths of the shared
    ReLU layers. Input (B, obs_dim) float32, output (B, n_actions) float32.
    """

    def __init__(self, obs_dim: int, n_actions: int, hidden: Sequence[int] = (128, 128)) -> None:
        super().__init__()
        if obs_dim < 1 or n_actions < 1 or not hidden or any(h < 1 for h in hidden):
            raise ConfigError(
                f"DuelingQNetwork: need obs_dim >= 1, n_actions >= 1 and positive hidden widths, "
                f"got obs_dim={obs_dim}, n_actions={n_actions}, hidden={tuple(hidden)}"
            )
        self.obs_dim = int(obs_dim)
        self.n_actions = int(n_actions)
        self.hidden = tuple(int(h) for h in hidden)
        layers: list[nn.Module] = []
        width = self.obs_dim
        for h in self.hidden:
            layers += [nn.Linear(width, h), nn.ReLU()]
            width = h
        self.body = nn.Sequential(*layers)
        self.value = nn.Linear(width, 1)
        self.advantage = nn.Linear(width, self.n_actions)

    def streams(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The two streams before aggregation: V (B, 1) and A (B, n_actions)."""
        features = self.body(obs)
        return self.value(features), self.advantage(features)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        value, advantage = self.streams(obs)
        # Subtracting the mean (not the max) makes V and A identifiable with stable targets.
        return value + advantage - advantage.mean(dim=-1, keepdim=True)
