"""The decision period: how many control steps one chosen action is held.

The paper's agent decides every 0.1 s control step. Beyond the paper (off by default,
docs/design/agent.md#decision-period), an env made with ``decision_steps=k`` holds each action for
k control steps and sums their rewards, so one env step is one decision;
``info["control_steps"]`` says how many ran (fewer when the episode ends inside the
period). The bound is ``limits.MAX_DECISION_STEPS``, the one the training config and a
policy's recorded terms (``agents.policy_terms``) are held to as well.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.limits import MAX_DECISION_STEPS, is_decision_period

StepResult = tuple[np.ndarray, float, bool, bool, dict[str, Any]]
"""What a Gymnasium step returns: (observation, reward, terminated, truncated, info)."""


def check_decision_steps(value: object, where: str = "decision_steps") -> int:
    """``value`` as a decision period; ConfigError naming ``where`` unless it is a whole
    number in [1, MAX_DECISION_STEPS]."""
    if not is_decision_period(value):
        raise ConfigError(
            f"{where} must be a whole number in [1, {MAX_DECISION_STEPS.value}], got {value!r}"
        )
    assert isinstance(value, int)
    return value


def held_step(control_step: Callable[[int], StepResult], index: int, period: int) -> StepResult:
    """One decision: ``control_step(index)`` up to ``period`` times, stopping when the
    episode ends; the last step's observation, flags and info, the summed reward, and
    ``info["control_steps"]``."""
    total, n = 0.0, 0
    while True:
        obs, r, terminated, truncated, info = control_step(index)
        total, n = total + r, n + 1
        if terminated or truncated or n >= period:
            break
    info["control_steps"] = n
    return obs, total, terminated, truncated, info
