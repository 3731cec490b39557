"""R = R1 + R2 + R3 (paper Eq. r1-r3), every branch pinned."""

from __future__ import annotations

import math

import pytest

from d3dwa_bullet.errors import ConfigError, UnknownNameError
from d3dwa_bullet.learning.reward import reward
from d3dwa_bullet.params import RewardParams

BASE = RewardParams()

# (outcome, expected R1 with baseline magnitudes)
R1_CASES = [(None, -0.02), ("goal", 50.0), ("collision", -2.02), ("timeout", -2.02)]
# (d_goal_prev, d_goal, expected R2)
R2_CASES = [(2.0, 1.9, 0.1), (2.0, 2.1, -0.1), (2.0, 2.0, 0.0)]
# (d_obs_prev, d_obs, expected R3)
R3_CASES = [
    (1.0, 0.9, -0.05),
    (1.0, 1.1, 0.05),
    (1.0, 1.0, 0.0),
    (math.inf, math.inf, 0.0),
    (math.inf, 3.0, -0.05),
]


@pytest.mark.parametrize(("outcome", "r1"), R1_CASES)
@pytest.mark.parametrize(("g0", "g1", "r2"), R2_CASES)
@pytest.mark.parametrize(("o0", "o1", "r3"), R3_CASES)
@pytest.mark.parametrize("scale", [1.0, 0.01])
def test_every_branch(outcome, r1, g0, g1, r2, o0, o1, r3, scale) -> None:
    params = RewardParams(scale=scale)
    assert reward(outcome, g0, g1, o0, o1, params) == pytest.approx(
        scale * (r1 + r2 + r3), abs=1e-12
    )


def test_goal_has_no_step_penalty() -> None:
    assert reward("goal", 1.0, 1.0, 1.0, 1.0, BASE) == 50.0


def test_timeout_and_collision_use_their_own_magnitudes() -> None:
    params = RewardParams(collision=-3.0, timeout=-5.0, step=-0.5)
    assert reward("collision", 1.0, 1.0, 1.0, 1.0, params) == -3.5
    assert reward("timeout", 1.0, 1.0, 1.0, 1.0, params) == -5.5


def test_d3qn_scale_example() -> None:
    # Closer to the goal, away from the obstacle, still running: (-0.02 + 0.1 + 0.05) / 100.
    assert reward(None, 3.0, 2.96, 0.5, 0.52, RewardParams(scale=0.01)) == pytest.approx(0.0013)


def test_unknown_outcome() -> None:
    with pytest.raises(UnknownNameError, match="crash"):
        reward("crash", 1.0, 1.0, 1.0, 1.0, BASE)  # type: ignore[arg-type]


@pytest.mark.parametrize("args", [(math.nan, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, math.nan)])
def test_nan_distance(args) -> None:
    with pytest.raises(ValueError, match="NaN"):
        reward(None, *args, BASE)


def test_stall_penalty_is_off_by_default_and_priced_only_after_stall_after() -> None:
    stalled = RewardParams(stall_penalty=-0.02, stall_after=5.0, scale=0.01)
    for outcome in (None, "collision", "timeout"):
        paper = reward(outcome, 2.0, 2.0, 1.0, 1.0, RewardParams(scale=0.01), 60.0)
        assert paper == reward(outcome, 2.0, 2.0, 1.0, 1.0, RewardParams(scale=0.01))
        assert reward(outcome, 2.0, 2.0, 1.0, 1.0, stalled, 5.0) == paper  # not yet
        assert reward(outcome, 2.0, 2.0, 1.0, 1.0, stalled, 5.1) == pytest.approx(paper - 0.0002)
    # reaching the goal is progress: never charged
    assert reward("goal", 2.0, 0.05, 1.0, 1.0, stalled, 30.0) == pytest.approx(0.501)


@pytest.mark.parametrize(
    ("changes", "field"),
    [({"stall_penalty": 0.1}, "stall_penalty"), ({"stall_after": 0.0}, "stall_after"),
     ({"stall_penalty": math.nan}, "stall_penalty")],
)  # fmt: skip
def test_bad_stall_fields_are_refused_by_name(changes: dict, field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        RewardParams(**changes)
