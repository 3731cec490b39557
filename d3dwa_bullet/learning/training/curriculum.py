"""The training curriculum: how often each task (a training world or a generator style) is drawn.

"uniform" keeps the env's base probabilities. "adaptive" draws each task with its base
probability times ``curriculum_floor + failure rate`` over its last ``curriculum_window``
rated episodes, so tasks the agent already solves are drawn less often (a task never
tried counts as always failed). The trainer rates only episodes from a task's own start
(not route starts), so the rate is that of the task as the greedy evaluation runs it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence

from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training.config import TrainConfig


class Curriculum:
    """Per-task outcome windows and the task weights they give (module docstring)."""

    def __init__(self, mode: str, window: int, floor: float) -> None:
        self.mode = mode
        self.window = window
        self.floor = floor
        self.history: dict[str, deque[int]] = {}
        """Task name -> 1 (goal) / 0 of its last ``window`` rated episodes."""

    @classmethod
    def of(cls, config: TrainConfig) -> Curriculum:
        """The curriculum of a training config."""
        return cls(config.curriculum, config.curriculum_window, config.curriculum_floor)

    def record(self, task: str, success: int) -> None:
        """Rate one finished episode of ``task`` (1 if it reached the goal, else 0)."""
        self.history.setdefault(task, deque(maxlen=self.window)).append(success)

    def weights(self, tasks: Sequence[str]) -> list[float]:
        """``floor + failure rate`` of each task, in ``tasks`` order."""
        weights = []
        for task in tasks:
            h = self.history.get(task)
            failure = 1.0 - (sum(h) / len(h)) if h else 1.0
            weights.append(self.floor + failure)
        return weights

    def apply(self, env: D3DWAEnv) -> None:
        """Set the env's task weights for the next episode ("uniform": leave them alone)."""
        if self.mode != "adaptive":
            return
        env.set_task_weights(self.weights(env.tasks))

    def to_dict(self) -> dict[str, list[int]]:
        """The outcome windows as JSON-ready lists (part of the training state)."""
        return {k: list(v) for k, v in self.history.items()}

    def load(self, history: Mapping[str, Sequence[int]]) -> None:
        """Restore the outcome windows saved by ``to_dict``."""
        self.history = {k: deque(v, maxlen=self.window) for k, v in history.items()}
