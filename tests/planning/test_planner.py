"""The DWA planner: window, criteria, normalisation, admissibility, and the brute-force check."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError, ScanError
from d3dwa_bullet.params import PlannerParams, RobotLimits
from d3dwa_bullet.planning.planner import (
    PlannerAction,
    _geometry,
    _score,
    dynamic_window,
    plan,
    rollout_steps,
)
from tests.support.reference_planner import normalise, reference_plan, select

SMALL = PlannerParams(n_v=5, n_w=9)
ACTION = PlannerAction(1.0, 1.0, 1.0, 2.0)


def ring(radius: float, n: int = 240, centre=(0.0, 0.0)) -> np.ndarray:
    a = np.linspace(-math.pi, math.pi, n, endpoint=False)
    return np.column_stack((centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)))


@pytest.mark.parametrize(
    ("v0", "w0", "expected"),
    [
        (0.0, 0.0, (0.0, 0.2, -0.3, 0.3)),
        (0.4, 0.0, (0.2, 0.4, -0.3, 0.3)),
        (0.1, 1.9, (0.0, 0.3, 1.6, 2.0)),
        (0.3, -2.0, (0.1, 0.4, -2.0, -1.7)),
    ],
)
def test_dynamic_window_respects_accelerations_and_limits(v0, w0, expected):
    assert dynamic_window(v0, w0, PlannerParams()) == pytest.approx(expected)


def test_window_never_allows_reverse_or_overspeed():
    lim = RobotLimits()
    for v0 in np.linspace(0, 0.4, 9):
        for w0 in np.linspace(-2, 2, 9):
            v_lo, v_hi, w_lo, w_hi = dynamic_window(v0, w0, PlannerParams())
            assert 0.0 <= v_lo <= v_hi <= lim.v_max
            assert -lim.w_max <= w_lo <= w_hi <= lim.w_max


def test_compiled_geometry_is_the_closed_form_arcs_offsets_progress_and_box():
    """plan() takes arcs, circle offsets, progress and the field box from one numba kernel."""
    t = rollout_steps(4.0, 0.1)
    assert len(t) == 40 and t[-1] == pytest.approx(4.0)
    ws = np.array([-1.3, -0.2, 0.0, 0.4, 2.0])
    vs = np.linspace(0.05, 0.3, 4)
    cx = np.array(PlannerParams().footprint.centers_x)
    goal = (2.0, -0.7)
    ux, uy, off_x, off_y, progress, box = _geometry(vs, ws, t, cx, *goal, 0.02, 51)
    assert ux[2] == pytest.approx(t) and uy[2] == pytest.approx(0.0)  # w = 0: straight
    th = ws[:, None] * t[None, :]
    turn = ws != 0.0
    w = ws[turn, None]
    np.testing.assert_allclose(ux[turn], np.sin(th[turn]) / w, atol=1e-12)
    np.testing.assert_allclose(uy[turn], (1 - np.cos(th[turn])) / w, atol=1e-12)
    np.testing.assert_allclose(off_x, np.cos(th)[:, :, None] * cx, atol=1e-12)
    np.testing.assert_allclose(off_y, np.sin(th)[:, :, None] * cx, atol=1e-12)
    end_x, end_y = vs[:, None] * ux[None, :, -1], vs[:, None] * uy[None, :, -1]
    expected = math.hypot(*goal) - np.hypot(goal[0] - end_x, goal[1] - end_y)
    np.testing.assert_allclose(progress, expected.ravel(), atol=1e-12)
    centres_x = vs[:, None, None, None] * ux[None, :, :, None] + off_x[None]
    centres_y = vs[:, None, None, None] * uy[None, :, :, None] + off_y[None]
    i = np.floor(centres_x / 0.02 + 0.5)
    j = np.floor(centres_y / 0.02 + 0.5)
    # Every circle centre's cell lies inside the box, which is tight up to the reach.
    assert box[0] + 51 <= i.min() <= box[0] + 52 and box[2] - 52 <= i.max() <= box[2] - 51
    assert box[1] + 51 <= j.min() <= box[1] + 52 and box[3] - 52 <= j.max() <= box[3] - 51


def test_compiled_scoring_matches_select():
    rng = np.random.default_rng(3)
    for trial in range(50):
        n = 60
        progress, clearance, speed = rng.normal(size=(3, n))
        speed[: trial % 3] = 0.5  # some criteria constant over small sets
        admissible = rng.random(n) < (0.0 if trial == 0 else 0.5)
        action = PlannerAction(*rng.choice([1.0, 2.0, 3.0], 3), 4.0)
        scores = np.empty(n)
        best = _score(progress, clearance, speed, admissible, *action[:3], scores)
        ref_scores, ref_best = select(progress, clearance, speed, admissible, action)
        assert best == ref_best
        np.testing.assert_allclose(scores, ref_scores, atol=1e-12)


def test_scoring_normalises_over_admissible_set_and_constant_criterion_to_zero():
    vals = np.array([1.0, 3.0, 5.0, 100.0])
    mask = np.array([True, True, True, False])
    const, scores = np.full(4, 2.0), np.empty(4)
    assert _score(vals, const, const, mask, 1.0, 1.0, 1.0, scores) == 2
    assert scores == pytest.approx([0.0, 0.5, 1.0, -np.inf])
    assert _score(const, const, const, mask, 1.0, 1.0, 1.0, scores) == 0  # first of equals
    assert scores[:3] == pytest.approx(0.0)
    assert _score(vals, vals, vals, np.zeros(4, bool), 1.0, 1.0, 1.0, scores) == -1
    assert np.isneginf(scores).all()


def test_open_space_goes_straight_at_the_goal_with_progress_weight():
    res = plan((0.4, 0.0), np.zeros((0, 2)), (3.0, 0.0), PlannerAction(3.0, 1.0, 1.0, 4.0))
    half_step = 0.5 * 0.6 / (PlannerParams().n_w - 1)  # the w grid has no exact 0 (40 samples)
    assert not res.fallback and res.v == pytest.approx(0.4) and abs(res.w) <= half_step + 1e-12
    assert res.admissible.all() and res.clearance == pytest.approx(PlannerParams().clearance_cap)


def test_goal_to_the_left_turns_left():
    res = plan((0.2, 0.0), np.zeros((0, 2)), (0.5, 2.0), PlannerAction(3.0, 1.0, 1.0, 2.0))
    assert res.w > 0


@pytest.mark.parametrize(("distance", "v0"), [(0.45, 0.2), (0.5, 0.1), (0.6, 0.2)])
def test_obstacle_dead_ahead_is_never_chosen_into(distance, v0):
    """A wall across the way, near enough that driving on means hitting it, far enough (and
    slow enough) that some turn is admissible: the planner must choose, not fall back."""
    wall = np.column_stack((np.full(50, distance), np.linspace(-1, 1, 50)))
    res = plan((v0, 0.0), wall, (3.0, 0.0), PlannerAction(1.0, 1.0, 3.0, 4.0))
    assert not res.fallback and res.index >= 0
    # The w grid has no exact 0: the samples nearest to straight on are the two closest to it.
    w = np.abs(res.samples[:, 1])
    straight = w <= w.min() + 1e-12
    moving = straight & (res.samples[:, 0] > 0.05)
    assert moving.sum() >= 2
    # Straight on at any speed would bring the front circle within r + m of the wall.
    assert not res.admissible[moving].any()
    assert res.clearance[res.index] > PlannerParams().admissible_clearance
    assert abs(res.w) > w.min()  # the chosen command turns away


def test_boxed_in_robot_falls_back_to_the_safest_motion_and_says_so():
    # A ring of points 0.25 m away with a bite taken out of its right: nothing is admissible,
    # the safest motion is to stop and turn away from the near side, whatever the goal says.
    pts = ring(0.25)
    pts = np.vstack((pts[pts[:, 1] > -0.05], [[0.12, -0.19]]))
    res = plan((0.0, 0.0), pts, (0.5, -2.0), ACTION)
    assert res.fallback and res.index == -1 and not res.admissible.any()
    assert np.isneginf(res.scores).all()
    assert res.v == 0.0


def test_scores_are_weighted_sum_of_normalised_criteria():
    pts = ring(1.0, centre=(1.5, 0.5))
    a = PlannerAction(2.0, 3.0, 1.0, 3.0)
    res = plan((0.2, 0.1), pts, (3.0, 0.0), a)
    m = res.admissible
    expected = (
        a.wp * normalise(res.progress, m)
        + a.wc * normalise(res.clearance, m)
        + a.ws * normalise(res.speed, m)
    )
    assert res.scores[m] == pytest.approx(expected[m])
    assert res.index == int(np.argmax(np.where(m, expected, -np.inf)))


@pytest.mark.parametrize(
    "bad", [np.array([[np.nan, 1.0]]), np.array([[1.0, np.inf]]), np.zeros((3, 3))]
)
def test_non_finite_or_misshapen_points_raise_scan_error(bad):
    with pytest.raises(ScanError):
        plan((0.0, 0.0), bad, (1.0, 0.0), ACTION)


def test_bad_planner_params_raise_config_error():
    with pytest.raises(ConfigError, match="n_v"):
        PlannerParams(n_v=0)
    with pytest.raises(ConfigError, match="grid_resolution"):
        PlannerParams(grid_resolution=0.0)


def _random_scene(rng):
    a = np.deg2rad(np.arange(-120, 120.01, 2.0))
    r = np.full(a.shape, rng.uniform(1.0, 3.0))
    for _ in range(int(rng.integers(1, 6))):
        c, half, d = rng.uniform(-2, 2), rng.uniform(0.05, 0.4), rng.uniform(0.3, 2.0)
        r = np.where(np.abs(a - c) < half, np.minimum(r, d), r)
    return np.column_stack((0.156 + r * np.cos(a), r * np.sin(a)))


@pytest.mark.parametrize("seed", range(12))
def test_fast_planner_matches_brute_force_reference(seed):
    rng = np.random.default_rng(seed)
    params = PlannerParams(n_v=6, n_w=11)
    pts = _random_scene(rng)
    vel = (rng.uniform(0, 0.4), rng.uniform(-2, 2))
    goal = rng.uniform(-1, 4, 2)
    action = PlannerAction(
        *(float(w) for w in rng.choice([1, 2, 3], 3)), float(rng.choice([2, 3, 4, 5]))
    )
    fast = plan(vel, pts, goal, action, params)
    v, w, index, clearance, admissible = reference_plan(vel, pts, goal, action, params)
    assert fast.index == index
    assert (fast.admissible == admissible).all()
    # Clearance equals the reference wherever it is reported in full (admissible samples).
    assert np.abs(fast.clearance[admissible] - clearance[admissible]).max(initial=0.0) < 1e-6
    assert index >= 0 and not fast.fallback  # these scenes have a choice: the check below runs
    assert (fast.v, fast.w) == pytest.approx((v, w))


def test_fast_planner_matches_reference_at_full_size():
    rng = np.random.default_rng(99)
    pts = _random_scene(rng)
    action = PlannerAction(1.0, 2.0, 1.0, 2.0)
    fast = plan((0.2, 0.3), pts, (2.0, 1.0), action)
    _, _, index, clearance, admissible = reference_plan((0.2, 0.3), pts, (2.0, 1.0), action)
    assert fast.index == index and (fast.admissible == admissible).all()
    assert np.abs(fast.clearance[admissible] - clearance[admissible]).max() < 1e-6


def test_distance_field_is_exact_and_the_same_on_every_call():
    """OpenCV's precise transform can differ by one ulp between calls on the same image
    (its vectorised paths depend on buffer alignment); the planner's field must not."""
    from d3dwa_bullet.planning.planner import _distance_field

    rng = np.random.default_rng(0)
    for _ in range(60):
        w, h = (int(n) for n in rng.integers(20, 300, 2))
        n = int(rng.integers(1, 300))
        cells = np.column_stack((rng.integers(0, w, n), rng.integers(0, h, n)))
        fields = [_distance_field(cells, (0, 0, w - 1, h - 1), 0.02).dist for _ in range(4)]
        for f in fields[1:]:
            assert np.array_equal(f, fields[0])
        jj, ii = np.divmod(np.arange(w * h), w)
        d2 = ((ii[:, None] - cells[:, 0]) ** 2 + (jj[:, None] - cells[:, 1]) ** 2).min(axis=1)
        exact = np.sqrt(d2.astype(np.float32)) * np.float32(0.02)
        assert np.array_equal(fields[0], exact)
