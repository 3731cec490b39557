"""Wall time by stage of a loop: a few accumulators, cheap enough for every control step.

The simulator and the episode charge each control step's parts to named stages (physics,
lidar, noise, estimator, observation, planner); the training loop adds its own (act, learn,
...). ``bench_train --json`` reports them as ``timing_s``, so a speed-up shows where it lands.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

perf = time.perf_counter


class StageClock:
    """Seconds spent per stage. ``t = clock.charge("lidar", t)`` adds ``perf() - t`` to the
    stage and returns the new time stamp, so consecutive stages chain without extra calls."""

    __slots__ = ("seconds",)

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def charge(self, stage: str, since: float) -> float:
        now = perf()
        self.seconds[stage] = self.seconds.get(stage, 0.0) + (now - since)
        return now

    def merge(self, other: Mapping[str, float], prefix: str = "") -> None:
        """Add another clock's seconds (e.g. a finished episode's, or a worker's)."""
        for stage, s in other.items():
            key = prefix + stage
            self.seconds[key] = self.seconds.get(key, 0.0) + s
