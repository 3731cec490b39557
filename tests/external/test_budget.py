"""A method's budget (docs/design/external-methods.md#external-methods): its declaration, checked, and the
guard's record of a call over it, on a clock the test moves by hand (no sleeping, no
simulator)."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.errors import ExternalMethodError
from d3dwa_bullet.external.guard import external_controller
from d3dwa_bullet.external.resolve import resolve
from d3dwa_bullet.params import RobotLimits
from d3dwa_bullet.planning.velocity_command import PlannerInputs
from tests.support.external_methods import CLOCK

HERE = "tests.support.external_methods"


def _inputs(period: float = 0.1) -> PlannerInputs:
    return PlannerInputs(
        np.zeros((0, 2)), np.zeros(3), np.zeros(2), np.array([1.0, 0.0]), RobotLimits(), period
    )


def test_the_declared_budget_is_read_and_none_means_the_control_period():
    assert resolve(f"{HERE}:OverBudget").budget_s == 0.05
    assert resolve(f"{HERE}:Straight").budget_s is None
    assert external_controller(resolve(f"{HERE}:OverBudget")).budget_s == 0.05


@pytest.mark.parametrize("name", ["NoTime", "TextBudget"])
def test_a_budget_that_is_not_seconds_is_refused_in_one_line(name):
    with pytest.raises(ExternalMethodError, match="budget_s .* is not a number of seconds > 0"):
        resolve(f"{HERE}:{name}")


@pytest.mark.parametrize(("name", "late"), [("OverBudget", True), ("InBudget", False)])
def test_a_call_over_the_budget_is_kept_with_its_time(name, late):
    controller = external_controller(resolve(f"{HERE}:{name}"))
    controller.clock = CLOCK
    controller.reset(0)
    answers = [controller.velocity(_inputs()) for _ in range(2)]  # type: ignore[misc]
    assert controller.late_call() is None and answers[0] == answers[1]
    controller.velocity(_inputs())  # type: ignore[misc]
    refusal = controller.late_call()
    if late:
        assert str(refusal) == (
            f"method '{HERE}:{name}': command() took 0.080 s at step 2, over its budget "
            "of 0.05 s (its budget_s)"
        )
    else:
        assert refusal is None
    assert controller.overruns == 0  # both within the control period: simulation counts none
    controller.velocity(_inputs())  # type: ignore[misc]
    assert controller.late_call() is None  # the latest call's, not the episode's
    controller.reset(1)
    assert controller.late_call() is None


def test_without_a_declaration_the_budget_is_the_control_period():
    controller = external_controller(resolve(f"{HERE}:LateChooser"))
    controller.clock = CLOCK
    controller.reset(0)
    controller.choose(np.zeros(12))
    assert controller.late_call() is None
    controller.choose(np.zeros(12))
    assert str(controller.late_call()).endswith(
        "choose() took 0.150 s at step 1, over its budget of 0.1 s (the control period)"
    )
    assert controller.overruns == 1 and controller.slowest_s == pytest.approx(0.15)
