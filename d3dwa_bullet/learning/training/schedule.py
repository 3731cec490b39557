"""When a training run logs, evaluates and checkpoints: one place for that cadence.

Each action has a period in environment steps (0: never) and the step it is next due at.
``Cadence.take(step)`` says whether it is due and, if so, moves the due step on by one
period, so an action checked only at episode ends (evaluation, checkpoint) fires once at
the first episode end at or past each multiple of its period.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from d3dwa_bullet.learning.training.config import TrainConfig


class Cadence:
    """Something done every ``every`` env steps (0: never), first at step ``every``."""

    def __init__(self, every: int) -> None:
        self.every = every
        self.next: float = every or math.inf
        """The step the action is next due at (inf: never)."""

    def take(self, step: int) -> bool:
        """True if the action is due at ``step``; then its next due step moves on."""
        if step >= self.next:
            self.next += self.every
            return True
        return False

    def state(self) -> int | float | None:
        """The next due step for the training state (None: never)."""
        return None if math.isinf(self.next) else self.next

    def restore(self, value: Any) -> None:
        """Restore a next due step saved by ``state``."""
        self.next = math.inf if value is None else value


@dataclass
class Schedule:
    """The cadence of the scalar log, the greedy evaluation and the ``latest`` checkpoint."""

    log: Cadence
    """Loss, epsilon, throughput and curriculum scalars (checked every step)."""
    eval: Cadence
    """Greedy evaluation (checked at episode ends)."""
    checkpoint: Cadence
    """The resumable ``latest`` checkpoint (checked at episode ends)."""

    @classmethod
    def of(cls, config: TrainConfig) -> Schedule:
        """The schedule of a training config (log_every, eval_every, checkpoint_every)."""
        return cls(
            Cadence(config.log_every), Cadence(config.eval_every), Cadence(config.checkpoint_every)
        )

    def to_dict(self) -> dict[str, Any]:
        """The next due steps, as the training state stores them."""
        return {
            "next_eval": self.eval.state(),
            "next_checkpoint": self.checkpoint.state(),
            "next_log": self.log.state(),
        }

    def load(self, state: Mapping[str, Any]) -> None:
        """Restore the next due steps saved by ``to_dict``."""
        self.eval.restore(state["next_eval"])
        self.checkpoint.restore(state["next_checkpoint"])
        self.log.restore(int(state["next_log"]))
