"""Value calibration: the discounted returns, the rule, and that training logs both figures."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.learning.value_calibration import (
    ValueCalibration,
    calibrate,
    calibrate_by_outcome,
    discounted_returns,
)


def test_discounted_returns_by_hand() -> None:
    g = discounted_returns([1.0, 0.0, 2.0], 0.5)
    assert g == pytest.approx([1.0 + 0.5 * 0.0 + 0.25 * 2.0, 0.0 + 0.5 * 2.0, 2.0])


def test_discounted_returns_refuses_bad_gamma() -> None:
    with pytest.raises(ValueError, match="gamma"):
        discounted_returns([1.0], 1.5)


def test_calibrate_pools_every_step_of_every_episode() -> None:
    # episode 1: G = [0.5 * 0.9, 0.5]; episode 2: G = [-0.1]
    cal = calibrate([[0.45, 0.5], np.array([-0.1])], [[0.0, 0.5], [-0.1]], 0.9)
    assert cal.pairs == 3 and cal.episodes == 2
    assert cal.mean_return == pytest.approx((0.45 + 0.5 - 0.1) / 3)
    assert cal.mean_q == pytest.approx(cal.mean_return)
    assert cal.calibrated


@pytest.mark.parametrize(
    ("mean_q", "mean_return", "judged_by", "calibrated"),
    [
        (0.3, 0.3, "ratio", True),
        (0.44, 0.3, "ratio", True),  # ratio 1.47
        (0.46, 0.3, "ratio", False),  # ratio 1.53
        (0.2, 0.3, "ratio", False),  # ratio 0.67 - eps
        (3.0, 0.3, "ratio", False),  # a diverged learner
        (0.06, 0.02, "gap", True),  # small return: |gap| 0.04
        (0.08, 0.02, "gap", False),  # |gap| 0.06
        (-0.2, 0.0, "gap", False),
        (float("nan"), 0.3, "ratio", False),
    ],
)
def test_the_rule(mean_q: float, mean_return: float, judged_by: str, calibrated: bool) -> None:
    cal = ValueCalibration(mean_q, mean_return, pairs=10, episodes=1)
    assert cal.judged_by == judged_by
    assert cal.calibrated is calibrated
    assert ("does NOT" in cal.describe()) is (not calibrated)


def test_by_outcome_separates_a_stall_from_the_paths_that_finish() -> None:
    # a finished path valued right, and a stall valued as if the goal were near
    q = [[0.45, 0.5], [0.4, 0.4, 0.4]]
    r = [[0.0, 0.5], [-0.01, -0.01, -0.01]]
    by = calibrate_by_outcome(q, r, ["goal", "timeout"], 0.9)
    assert list(by) == ["goal", "not goal"]
    assert by["goal"].calibrated and by["goal"].episodes == 1
    assert not by["not goal"].calibrated and by["not goal"].pairs == 3
    assert by["not goal"].gap == pytest.approx(0.4 - np.mean([-0.0271, -0.019, -0.01]))
    assert not calibrate(q, r, 0.9).calibrated  # pooled, the stall hides the paths
    only_goals = calibrate_by_outcome(q[:1], r[:1], ["goal"], 0.9)
    assert list(only_goals) == ["goal"]
    with pytest.raises(ValueError, match="outcomes"):
        calibrate_by_outcome(q, r, ["goal"], 0.9)


def test_calibrate_refuses_mismatched_lengths() -> None:
    with pytest.raises(ValueError, match="Q values"):
        calibrate([[0.1, 0.2]], [[0.1]], 0.9)
