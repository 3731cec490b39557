"""The episode score (docs/design/score.md#score): both forms against values worked by hand."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from d3dwa_bullet.episode_metrics import (
    BARN_CLIP,
    BARN_SPEED,
    ROBOT_CLIP,
    barn_score,
    episode_score,
    path_score,
)
from d3dwa_bullet.evaluation.scores import score_cells
from d3dwa_bullet.world.barn import barn_world
from d3dwa_bullet.world.model import Cylinder, World
from d3dwa_bullet.world.routes import official_length, reference_length, shortest_path

# L = 2 m. Robot form at v_max 0.4 m/s: t_ref = 5 s, clip [5, 40] s.
# BARN's form: t_opt = 2 / 2 = 1 s, clip [2, 8] s.


@pytest.mark.parametrize(
    ("time_s", "expected"),
    [
        (10.0, 0.5),  # 5 / 10, inside the clip
        (20.0, 0.25),  # 5 / 20
        (5.0, 1.0),  # exactly t_ref
        (3.0, 1.0),  # faster than t_ref: clipped up to t_ref
        (0.0, 1.0),
        (40.0, 0.125),  # exactly 8 t_ref
        (100.0, 0.125),  # slower: clipped down to 8 t_ref
    ],
)
def test_robot_form_by_hand(time_s, expected):
    assert episode_score(True, time_s, 2.0, 0.4) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("time_s", "expected"),
    [
        (1.5, 0.5),  # below 2 t_opt: clipped to 2 s -> 1 / 2
        (2.0, 0.5),
        (4.0, 0.25),  # 1 / 4
        (8.0, 0.125),  # exactly 8 t_opt
        (30.0, 0.125),  # every slower success: 1 / 8
    ],
)
def test_barn_official_form_by_hand(time_s, expected):
    assert barn_score(True, time_s, 2.0) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("time_s", [0.0, 3.0, 12.0, 99.0])
def test_a_failure_scores_zero_in_both_forms(time_s):
    assert episode_score(False, time_s, 2.0, 0.4) == 0.0
    assert barn_score(False, time_s, 2.0) == 0.0


def test_the_constants_are_barns_and_the_robot_forms():
    assert (BARN_SPEED, BARN_CLIP, ROBOT_CLIP) == (2.0, (2.0, 8.0), (1.0, 8.0))


def test_kachaka_times_a_flat_official_form_does_not_tell_apart_the_robot_form_does():
    # L = 4 m: Kachaka takes 10 s at best; 16 s and 30 s are both above 8 t_opt = 16 s
    assert barn_score(True, 16.0, 4.0) == barn_score(True, 30.0, 4.0) == 0.125
    assert episode_score(True, 16.0, 4.0, 0.4) == pytest.approx(10 / 16)
    assert episode_score(True, 30.0, 4.0, 0.4) == pytest.approx(10 / 30)


@pytest.mark.parametrize(
    ("args", "word"),
    [
        ((True, math.nan, 2.0, 0.4, (1.0, 8.0)), "time"),
        ((True, -1.0, 2.0, 0.4, (1.0, 8.0)), "time"),
        ((True, 5.0, 0.0, 0.4, (1.0, 8.0)), "reference length"),
        ((True, 5.0, math.inf, 0.4, (1.0, 8.0)), "reference length"),
        ((True, 5.0, 2.0, 0.0, (1.0, 8.0)), "speed"),
        ((True, 5.0, 2.0, 0.4, (8.0, 1.0)), "clip"),
        ((False, 5.0, -2.0, 0.4, (1.0, 8.0)), "reference length"),  # checked on failures too
    ],
)
def test_bad_arguments_are_refused(args, word):
    with pytest.raises(ValueError, match=word):
        path_score(*args)


def test_the_robot_form_takes_the_route_and_the_official_form_the_published_path():
    post = World("post", "d", (0.0, 0.0, 0.0), (2.5, 0.0), (Cylinder((1.2, 0.0), 0.15),))
    route = reference_length(post)
    assert route == shortest_path(post).length and 2.5 < route < 3.0  # around the post
    assert official_length(post) == route  # no published path: the same L
    published = replace(post, reference_length=3.7)  # a BARN-like grid path, longer
    assert reference_length(published) == route and official_length(published) == 3.7


def test_a_barn_world_scores_against_its_route_not_its_longer_grid_path():
    world = barn_world(0)  # BARN's published path 13.59 m; the drivable route about 10.3 m
    route = reference_length(world)
    assert 10.0 <= route < 10.5 < world.reference_length == official_length(world)
    # DWA III's noise-free time on BARN-0 (32.0 s): the robot form no longer sits at its clip
    cells = score_cells("goal", 32.0, route, 0.4, official_length(world))
    assert cells["score"] == pytest.approx(route / 0.4 / 32.0, abs=1e-5) and cells["score"] < 0.9
    assert cells["score_barn"] == pytest.approx(
        barn_score(True, 32.0, world.reference_length), abs=1e-6
    )


def test_without_a_route_for_the_footprint_the_straight_line_is_taken():
    # a gap of 0.3 m between two posts: narrower than 2 (r + m) = 0.4 m, no other way round
    walls = (Cylinder((1.0, 0.0), 0.15),)
    blocked = World("blocked", "d", (0.0, 0.0, 0.0), (1.0, 0.3), walls)  # goal 0.15 m from it
    assert reference_length(blocked) == pytest.approx(math.hypot(1.0, 0.3))
    assert reference_length(World("here", "d", (0.0, 0.0, 0.0), (0.0, 0.0))) == 0.02
