"""Running a method from outside the package as a controller, with every answer checked
(docs/design/external-methods.md#external-methods).

:class:`ExternalController` is the built-in :class:`~d3dwa_bullet.planning.controller.Controller`
with the method's calls in place of a policy (a chooser) or of the DWA (a velocity planner).
Each call gets copies of its inputs, so nothing the method does to them reaches the
episode; each answer is checked before it is used: a chooser's must be a whole number in its
action set, a velocity planner's two finite numbers within the robot's velocity limits (the
simulator, the replay and the robot's clamp then limit the accelerations as for any method).
A call that raises or answers otherwise ends the run: ExternalMethodError, one line naming
the method, the call, the step and what was wrong. A call that takes longer than the control
period is counted (``overruns``, ``slowest_s``): a simulated episode does not wait for it.
A call of ``choose`` or ``command`` longer than the method's budget (its class's ``budget_s``,
default the control period) is kept (:meth:`ExternalController.late_call`): ``drive`` stops
the robot on it.
"""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from d3dwa_bullet.errors import ExternalMethodError
from d3dwa_bullet.external.resolve import METHOD_FAULTS, ExternalMethod, _said
from d3dwa_bullet.params import SimParams
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.planning.velocity_command import NO_PARAMETERS, PlannerInputs


@dataclass
class ExternalController(Controller):
    """A controller whose choices (or commands) come from an external method's instance."""

    method: Any = None
    """The method's instance (:meth:`ExternalMethod.build`)."""
    period: float = SimParams().control_period
    """The control period, s (a velocity planner's from its inputs)."""
    budget_s: float | None = None
    """The time one call may take in ``drive``, s (None: ``period``)."""
    clock: Callable[[], float] = time.perf_counter
    """What a call is timed by, s (tests inject theirs)."""
    overruns: int = 0
    """Calls this episode that took longer than ``period``."""
    slowest_s: float = 0.0
    """The slowest call this episode, s."""
    _step: int = field(default=0, init=False, repr=False)
    _late: str | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.fixed is None:  # a chooser: its index in place of a policy's
            self.policy = self._choose
        else:  # a velocity planner: its command in place of the DWA's
            self.velocity = self._command

    def reset(self, episode_seed: int) -> None:
        super().reset(episode_seed)
        self.overruns, self.slowest_s, self._step = 0, 0.0, 0
        self._call("reset", self.method.reset, int(episode_seed))
        self._late = None  # reset() is not on the clock: the robot is not moving yet

    def late_call(self) -> ExternalMethodError | None:
        """The refusal of the latest ``choose`` or ``command`` call if it took longer than
        the budget (one line: the method, the call, its time, the budget); None otherwise."""
        return None if self._late is None else ExternalMethodError(self._late)

    def _call(self, what: str, fn: Callable[..., Any], *args: Any) -> Any:
        start = self.clock()
        try:
            out = fn(*args)
        except METHOD_FAULTS as err:  # the method's own code: whatever it raises or exits with
            raise ExternalMethodError(
                f"method {self.name!r}: {what}() raised at step {self._step}: {_said(err)}"
            ) from err
        elapsed = self.clock() - start
        self.slowest_s = max(self.slowest_s, elapsed)
        if elapsed > self.period:
            self.overruns += 1
        budget = self.period if self.budget_s is None else self.budget_s
        self._late = None
        if elapsed > budget:
            declared = "its budget_s" if self.budget_s is not None else "the control period"
            self._late = (
                f"method {self.name!r}: {what}() took {elapsed:.3f} s at step {self._step}, "
                f"over its budget of {budget:g} s ({declared})"
            )
        return out

    def _refuse(self, what: str, out: Any, why: str) -> ExternalMethodError:
        return ExternalMethodError(
            f"method {self.name!r}: {what}() returned {out!r:.60} at step {self._step}: {why}"
        )

    def _choose(self, obs: np.ndarray) -> int:
        out = self._call("choose", self.method.choose, np.array(obs, dtype=np.float64))
        n = len(self.actions)  # type: ignore[arg-type]
        if not isinstance(out, numbers.Integral) or isinstance(out, bool | np.bool_):
            raise self._refuse("choose", out, f"not a whole number (an index in [0, {n}))")
        if not 0 <= int(out) < n:
            raise self._refuse("choose", out, f"not an index of its {n} actions")
        self._step += self.hold
        return int(out)

    def _command(self, inputs: PlannerInputs) -> tuple[float, float]:
        self.period = inputs.control_period
        out = self._call("command", self.method.command, inputs)
        if isinstance(out, np.ndarray):
            out_seq: Any = out.tolist() if out.ndim == 1 else out
        else:
            out_seq = out
        if not isinstance(out_seq, tuple | list) or len(out_seq) != 2:
            raise self._refuse("command", out, "not a pair (v m/s, w rad/s)")
        if not all(isinstance(x, numbers.Real) and not isinstance(x, bool) for x in out_seq):
            raise self._refuse("command", out, "not two real numbers")
        v, w = float(out_seq[0]), float(out_seq[1])
        if not (math.isfinite(v) and math.isfinite(w)):
            raise self._refuse("command", out, "not finite")
        lim = inputs.limits
        if abs(v) > lim.v_max or abs(w) > lim.w_max:
            raise self._refuse(
                "command", out,
                f"beyond the robot's limits (|v| <= {lim.v_max:g} m/s, |w| <= {lim.w_max:g} rad/s)",
            )  # fmt: skip
        self._step += 1
        return v, w


def external_controller(method: ExternalMethod) -> ExternalController:
    """The controller of a resolved external method, with a new instance of it."""
    instance = method.build()
    if method.kind == "velocity planner":
        return ExternalController(
            method.name, fixed=NO_PARAMETERS, method=instance, origin=method.origin,
            source=f"external velocity planner from {method.origin}", budget_s=method.budget_s,
        )  # fmt: skip
    held = f" (one decision every {method.hold} control steps)" if method.hold > 1 else ""
    return ExternalController(
        method.name, actions=method.actions, hold=method.hold, observation=method.observation,
        method=instance, origin=method.origin, source=f"external parameter chooser from {method.origin}{held}",
        budget_s=method.budget_s,
    )  # fmt: skip
