"""Exact re-runs of an env's episodes, for resuming a training run bit for bit.

An env's ``reset_rng_state`` is its RNG's state just before an episode's draw; ``rebuild``
restores it and replays that episode's actions, so the episode stands where it stood, and
later resets draw what they drew the first time (``training.state.rebuild_plans``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


class Rebuild:
    """``rebuild`` and ``rebuild_from_plan`` for a Gymnasium env (mixed into ``D3DWAEnv``)."""

    np_random: np.random.Generator
    reset: Any  # the env's own reset and step
    step: Any

    def rebuild(
        self, rng_state: Mapping[str, Any], actions: Sequence[int], task_weights: Any = None
    ) -> np.ndarray:
        """Re-run an episode exactly: restore the env RNG to ``rng_state`` (a former
        ``reset_rng_state``), reset with ``task_weights`` (those of that reset), take
        ``actions``; returns the observation reached. The env RNG then stands where it stood
        after that episode's reset, so later resets draw what they drew the first time."""
        self.np_random = np.random.Generator(np.random.PCG64(0))
        self.np_random.bit_generator.state = dict(rng_state)
        options = {} if task_weights is None else {"task_weights": task_weights}
        obs, _ = self.reset(options=options)
        for i, a in enumerate(actions):
            obs, _, terminated, truncated, _ = self.step(a)
            if (terminated or truncated) and i + 1 < len(actions):
                raise RuntimeError(
                    f"Rebuild.rebuild: the episode ended after {i + 1} of {len(actions)} actions"
                )
        return obs

    rebuild_plan: Mapping[str, Any] | None = None
    """What ``rebuild_from_plan`` re-runs: {"rng_state", "actions", "task_weights"} (set
    per env through a vector env's ``set_attr``, then called through ``call``)."""

    def rebuild_from_plan(self) -> np.ndarray:
        plan = self.rebuild_plan
        if plan is None:
            raise RuntimeError("Rebuild.rebuild_from_plan: no rebuild_plan set")
        return self.rebuild(plan["rng_state"], plan["actions"], plan.get("task_weights"))
