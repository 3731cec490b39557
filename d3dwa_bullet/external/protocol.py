"""The interface a method from outside the package implements, version 1
(docs/design/external-methods.md#external-methods).

Two kinds, told apart by the one call each has:

* a **parameter chooser** (``choose``): the observation in, an action index of its declared
  action set out; the testbed's DWA, scan filter and recovery layer do the rest. The
  built-in methods' :class:`~d3dwa_bullet.planning.controller.Controller` has this surface.
* a **velocity planner** (``command``): :class:`PlannerInputs` in (the filtered scan's points,
  the estimated pose and velocity, the goal in base_link, the limits), (v m/s, w rad/s) out;
  it replaces the DWA, and the recovery layer wraps it as it wraps the DWA.

A method is a class built with no arguments, named ``package.module:Name`` or registered under
the entry point group :data:`ENTRY_POINT_GROUP` (the naming rules: :mod:`d3dwa_bullet.method_names`).
Its class declares ``interface_version`` (:data:`INTERFACE_VERSION`). It is given copies of its inputs, never the simulator; whatever
it returns is checked (a finite index in its set, a finite command within the limits) and a
method that raises or answers otherwise ends the run, refused in one line.

Either kind may declare ``budget_s``: the time one ``choose`` or ``command`` call may take, s
(a number > 0; default the control period). In ``d3dwa drive`` the first call over it stops
the robot (a zero command in place of its answer) and ends the run; in simulation a call over
the control period is counted, never waited for.

Pure: the standard library and numpy; the method's own module is imported only when it runs
(:mod:`d3dwa_bullet.external.resolve`).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from d3dwa_bullet.method_names import ENTRY_POINT_GROUP
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.velocity_command import PlannerInputs

__all__ = [
    "ENTRY_POINT_GROUP",
    "INTERFACE_VERSION",
    "ParameterChooser",
    "PlannerInputs",
    "VelocityPlanner",
]

#: The version of this interface; a method's class declares the one it implements.
INTERFACE_VERSION = 1


@runtime_checkable
class ParameterChooser(Protocol):
    """Observation in, an index of ``actions`` out, every ``hold`` control steps.

    actions: the action set it chooses from (one of the shipped sets: 100 actions of
    weights x horizon, or the 25 weight triples at a 4 s horizon, so its floors exist);
    hold: its decision period, control steps (1: every step); observation: the kind it reads
    (``paper``: the 12-d state of docs/design/observation.md#observation)."""

    actions: ActionSet
    hold: int
    observation: str

    def reset(self, episode_seed: int) -> None:
        """Start an episode (seed >= 0: a method that draws seeds its own generator here)."""

    def choose(self, obs: np.ndarray) -> int:
        """obs: (D,) float64, a copy. Returns an index in [0, len(actions))."""
        ...


@runtime_checkable
class VelocityPlanner(Protocol):
    """Planner inputs in, a velocity command out, every control step."""

    def reset(self, episode_seed: int) -> None:
        """Start an episode."""

    def command(self, inputs: PlannerInputs) -> tuple[float, float]:
        """(v m/s, w rad/s), finite, |v| <= limits.v_max and |w| <= limits.w_max; the
        robot's accelerations limit how fast the command is reached."""
        ...
