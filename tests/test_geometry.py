"""Planar geometry: the angle wraps at their interval edges, the unicycle arc, outlines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from d3dwa_bullet.geometry import (
    arc_step,
    body_outline,
    circle_polygon,
    rectangle_corners,
    wrap_angle,
    wrap_angle_modular,
    wrap_angles,
)
from d3dwa_bullet.robot import BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH

PI = math.pi
ANGLES = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_subnormal=False)


@pytest.mark.parametrize(
    ("a", "wrapped"),
    [
        (PI, PI),
        (-PI, PI),
        (math.nextafter(-PI, 0.0), math.nextafter(-PI, 0.0)),
        (3 * PI, PI),
        (-3 * PI, PI),
        (2 * PI, 0.0),
        (0.0, 0.0),
        (1e-300, 1e-300),
    ],
)
def test_wrap_angle_edges_of_minus_pi_to_pi(a, wrapped):
    assert wrap_angle(a) == pytest.approx(wrapped, abs=1e-15)
    assert wrap_angles(np.array([a]))[0] == pytest.approx(wrapped, abs=1e-15)


def test_wrap_angle_keeps_values_in_range_bit_for_bit():
    values = np.array([PI, math.nextafter(-PI, 0.0), 0.1, -3.0, 1e-300, -0.0])
    assert [wrap_angle(float(a)) for a in values] == values.tolist()
    np.testing.assert_array_equal(wrap_angles(values), values)


@given(ANGLES)
def test_wrap_angle_is_in_interval_and_a_whole_number_of_turns_away(a):
    w = wrap_angle(a)
    assert -PI < w <= PI
    turns = (a - w) / (2 * PI)
    assert turns == pytest.approx(round(turns), abs=1e-9)
    assert wrap_angles(np.array([a]))[0] == w


def test_wrap_angle_stays_in_range_next_to_large_odd_multiples_of_pi():
    # the plain ceil formula lands one ulp outside (-pi, pi] next to e.g. -39 pi
    for k in range(-60, 61, 2):
        for a in (k * PI + PI, math.nextafter(k * PI + PI, math.inf)):
            assert -PI < wrap_angle(a) <= PI
            assert -PI < wrap_angles(np.array([a]))[0] <= PI


def test_wrap_angle_modular_is_the_simulators_minus_pi_to_pi():
    assert wrap_angle_modular(PI) == -PI
    assert wrap_angle_modular(-PI) == -PI
    assert wrap_angle_modular(3 * PI) == pytest.approx(-PI)
    assert wrap_angle_modular(0.25) == (0.25 + PI) % (2.0 * PI) - PI
    # it re-rounds values in range, which wrap_angle does not: they are different numbers
    assert wrap_angle_modular(1e-20) == 0.0 != wrap_angle(1e-20)


def test_arc_step_over_a_whole_horizon_matches_the_closed_forms():
    # the oracle holds each command for its action's tau (2-5 s), far beyond one control period
    assert arc_step(1.0, 2.0, 0.0, 0.4, 0.0, 2.0)[:2] == pytest.approx((1.8, 2.0))  # straight
    r = 2 / math.pi  # quarter circle to the left: radius v / w
    assert arc_step(1.0, 2.0, 0.0, 1.0, math.pi / 2, 1.0)[:2] == pytest.approx((1.0 + r, 2.0 + r))
    assert arc_step(1.0, 2.0, 0.0, 0.0, 1.0, 3.0)[:2] == pytest.approx((1.0, 2.0))  # in place


def test_arc_step_over_a_whole_horizon_agrees_with_integrating_the_unicycle():
    pose, v, w, tau = (0.3, -0.2, 0.7), 0.35, -1.3, 4.0
    x, y, th = pose
    n = 40000
    for _ in range(n):
        x += v * math.cos(th) * tau / n
        y += v * math.sin(th) * tau / n
        th += w * tau / n
    assert arc_step(*pose, v, w, tau)[:2] == pytest.approx((x, y), abs=1e-4)


def test_arc_step_yaw_is_not_wrapped_and_is_smooth_through_zero_turn_rate():
    assert arc_step(0.0, 0.0, 3.0, 0.0, 1.0, 1.0)[2] == 4.0
    near = arc_step(0.0, 0.0, 0.5, 0.3, 1e-12, 1.0)
    assert near[:2] == pytest.approx(arc_step(0.0, 0.0, 0.5, 0.3, 0.0, 1.0)[:2], abs=1e-12)


def test_body_outline_spans_the_body_box_at_a_pose():
    pts = body_outline((0.0, 0.0, 0.0))
    assert pts.shape == (32, 2)
    assert pts[:, 0].min() == pytest.approx(BODY_CENTER_X - BODY_HALF_LENGTH)
    assert pts[:, 0].max() == pytest.approx(BODY_CENTER_X + BODY_HALF_LENGTH)
    assert np.abs(pts[:, 1]).max() == pytest.approx(BODY_HALF_WIDTH)
    turned = body_outline(np.array([[1.0, 2.0, math.pi / 2], [0.0, 0.0, 0.0]]), 4)
    assert turned.shape == (2, 16, 2)
    # a quarter turn to the left maps body (x, y) to world (1 - y, 2 + x)
    flat = body_outline((0.0, 0.0, 0.0), 4)
    np.testing.assert_allclose(turned[0], np.column_stack((1 - flat[:, 1], 2 + flat[:, 0])))


def test_rectangle_corners_and_circle_polygon():
    corners = rectangle_corners((1.0, 2.0), (2.0, 1.0), math.pi / 2)
    np.testing.assert_allclose(
        corners, [[1.5, 1.0], [1.5, 3.0], [0.5, 3.0], [0.5, 1.0]], atol=1e-12
    )
    ring = circle_polygon((1.0, -1.0), 0.5, 48)
    assert ring.shape == (48, 2)
    np.testing.assert_allclose(np.hypot(ring[:, 0] - 1.0, ring[:, 1] + 1.0), 0.5)
    assert ring[0].tolist() == [1.5, -1.0]
