"""Methods from outside the package, for the tests of d3dwa_bullet.external: each one named
``tests.support.external_methods:<Class>`` as a user would name their own."""

from __future__ import annotations

import sys
import time

import numpy as np

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ActionSet

#: What the mutating methods saw, to show the episode did not see their writes.
SEEN: list[np.ndarray] = []


class BuiltinChooser:
    """A built-in method through the external interface: its controller's own calls."""

    interface_version = 1
    builtin = "random"
    actions = ACTIONS_FULL
    hold = 1
    observation = "paper"

    def __init__(self) -> None:
        self.inner = make_controller(self.builtin)

    def reset(self, episode_seed: int) -> None:
        self.inner.reset(episode_seed)

    def choose(self, obs: np.ndarray) -> int:
        return self.inner.choose(obs)


class HeldRandom(BuiltinChooser):
    """``random@10`` as an external chooser: ``random``'s draws, declared held 10 steps."""

    hold = 10


class LearnedD3DWA(BuiltinChooser):
    """The shipped d3dwa policy through the external interface."""

    builtin = "d3dwa"


class Straight:
    """A velocity planner: straight on at a third of the limit, the goal ignored."""

    interface_version = 1

    def reset(self, episode_seed: int) -> None:
        pass

    def command(self, inputs) -> tuple[float, float]:
        return inputs.limits.v_max / 3, 0.0


class MutatingPlanner(Straight):
    """Writes over every array it is given (and keeps what it saw)."""

    def command(self, inputs) -> tuple[float, float]:
        for a in (inputs.points, inputs.pose, inputs.velocity, inputs.goal):
            a[...] = 1e6
        SEEN.append(inputs.points)
        return super().command(inputs)


class Zero(BuiltinChooser):
    """Always the first action."""

    builtin = "dwa3"

    def choose(self, obs: np.ndarray) -> int:
        return 0


class MutatingChooser(Zero):
    """Writes over the observation it is given."""

    def choose(self, obs: np.ndarray) -> int:
        obs[...] = -1e6
        return super().choose(obs)


class Answers(Straight):
    """A velocity planner that answers ``answer`` from its 3rd command on."""

    answer: object = (0.0, 0.0)

    def __init__(self) -> None:
        self.calls = 0

    def command(self, inputs):
        self.calls += 1
        return self.answer if self.calls >= 3 else (0.1, 0.0)


class NaNCommand(Answers):
    answer = (float("nan"), 0.0)


class TooFast(Answers):
    answer = (0.9, 0.0)


class ThreeNumbers(Answers):
    answer = (0.1, 0.0, 0.0)


class TextCommand(Answers):
    answer = ("0.1", 0.0)


class RaisesMidEpisode(Answers):
    def command(self, inputs):
        if self.calls >= 4:
            raise ZeroDivisionError("the method's own bug")
        return super().command(inputs)


class OutOfSet(BuiltinChooser):
    builtin = "dwa3"

    def choose(self, obs: np.ndarray) -> int:
        return 100


class FloatIndex(OutOfSet):
    def choose(self, obs: np.ndarray) -> float:
        return 3.0


class RaisesAtConstruction(Straight):
    def __init__(self) -> None:
        raise RuntimeError("no licence file")


class Version2(Straight):
    interface_version = 2


class Both(Straight):
    def choose(self, obs):
        return 0


class OddActions(BuiltinChooser):
    builtin = "dwa3"
    actions = ActionSet(horizons=(2.0,))


class Slow(Straight):
    """Takes longer than the control period at its 2nd command."""

    def __init__(self) -> None:
        self.calls = 0

    def command(self, inputs):
        self.calls += 1
        if self.calls == 2:
            time.sleep(inputs.control_period * 1.5)
        return super().command(inputs)


NOT_A_CLASS = 3


class HeldRandomToo(HeldRandom):
    """The same declaration as HeldRandom from another class: another source."""


class LookThenStill(Straight):
    """A velocity planner that turns on the spot for 4 s (its lidar sees all around), then
    stands still for good: the recovery layer has to move the robot."""

    def reset(self, episode_seed: int) -> None:
        self.calls = 0

    def command(self, inputs) -> tuple[float, float]:
        self.calls += 1
        return 0.0, (1.0 if self.calls <= 40 else 0.0)


class ManualClock:
    """A clock that moves only when told, s: inject it as an ExternalController's ``clock``
    and a call takes exactly what the method adds, whatever the machine does."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


#: The clock the budgeted methods below take their time on.
CLOCK = ManualClock()


class OverBudget(Straight):
    """A velocity planner declaring a 50 ms budget whose 3rd command takes ``takes`` s on
    CLOCK (every other call takes none)."""

    budget_s = 0.05
    takes = 0.08

    def reset(self, episode_seed: int) -> None:
        self.calls = 0

    def command(self, inputs) -> tuple[float, float]:
        self.calls += 1
        if self.calls == 3:
            CLOCK.now += self.takes
        return super().command(inputs)


class InBudget(OverBudget):
    """The same, its 3rd command within the budget."""

    takes = 0.04


class LateChooser(Zero):
    """A chooser with no declared budget (the control period) whose 2nd call takes 0.15 s
    on CLOCK."""

    def reset(self, episode_seed: int) -> None:
        super().reset(episode_seed)
        self.calls = 0

    def choose(self, obs: np.ndarray) -> int:
        self.calls += 1
        if self.calls == 2:
            CLOCK.now += 0.15
        return super().choose(obs)


class NoTime(Straight):
    budget_s = 0.0


class TextBudget(Straight):
    budget_s = "0.1"


class ExitsAtConstruction(Straight):
    """Its ``__init__`` calls ``sys.exit(code)``: a careless method's way to say it cannot run."""

    code = 0

    def __init__(self) -> None:
        sys.exit(self.code)


class ExitsSevenAtConstruction(ExitsAtConstruction):
    code = 7


class ExitsOnTenthCommand(Straight):
    """Drives straight on, then calls ``sys.exit(0)`` in its ``at``-th ``command()``."""

    at = 10

    def __init__(self) -> None:
        self.calls = 0

    def command(self, inputs):
        self.calls += 1
        if self.calls == self.at:
            sys.exit(0)
        return super().command(inputs)


class ExitsOnFifthCommand(ExitsOnTenthCommand):
    at = 5
