"""The record of one episode: its outcome, metrics and per-step log, and the row it writes.

What :func:`d3dwa_bullet.episode.run_episode` returns; results, tables and figures read it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

LOG_FIELDS = (
    "t",
    "x",
    "y",
    "yaw",
    "est_x",
    "est_y",
    "est_yaw",
    "v_cmd",
    "w_cmd",
    "action",
    "wp",
    "wc",
    "ws",
    "tau",
    "fallback",
    "recovery",
)
"""Per-step log columns; ``recovery`` is 0 when the controller and planner drove the step,
else the 1-based index of the recovery behaviour in ``params.RECOVERY_BEHAVIOURS``."""


@dataclass
class EpisodeResult:
    """Outcome, metrics and the per-step log of one episode."""

    world: str
    method: str
    seed: int
    outcome: str
    time_s: float
    tl_m: float
    pd_rad: float
    min_clearance_m: float
    steps: int
    noise: str = "none"
    recovery: str = "none"
    """The recovery layer the episode ran with (``--recovery``)."""
    backend: str = "pybullet"
    """The simulator backend that ran the episode (``--backend``)."""
    global_plan: str = "none"
    """The global plan followed (``--global-plan``; its paths and status are in the log)."""
    source: str = ""
    """Where a method from outside the package came from (``Controller.origin``); empty for
    a built-in method."""
    overruns: int = 0
    """Calls of a method from outside the package that took longer than the control period
    (the simulation did not wait for them: docs/design/external-methods.md#external-methods)."""
    log: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    observations: np.ndarray = field(default_factory=lambda: np.zeros((0, 12)), repr=False)

    def summary(self) -> dict[str, Any]:
        """The JSON/CSV row: world, method, seed, noise, outcome, time_s, tl_m, pd_rad,
        min_clearance_m, steps, recovery and global_plan when they ran (a paper-track row keeps
        the paper track's columns), backend when it is not PyBullet, and method_source and overruns
        for a method from outside the package."""
        row = {
            "world": self.world,
            "method": self.method,
            "seed": self.seed,
            "noise": self.noise,
            "outcome": self.outcome,
            "time_s": round(self.time_s, 3),
            "tl_m": round(self.tl_m, 4),
            "pd_rad": round(self.pd_rad, 4),
            "min_clearance_m": round(self.min_clearance_m, 4),
            "steps": self.steps,
        }
        if self.recovery != "none":
            row["recovery"] = self.recovery
        if self.backend != "pybullet":
            row["backend"] = self.backend
        if self.global_plan != "none":
            row["global_plan"] = self.global_plan
        if self.source:
            row |= {"method_source": self.source, "overruns": self.overruns}
        return row
