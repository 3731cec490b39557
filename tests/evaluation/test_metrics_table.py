"""Metrics (TL, PD, clearance) and the paper-layout tables."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.episode_metrics import body_clearance, posture_displacement, trajectory_length
from d3dwa_bullet.evaluation.tables import paper_table
from d3dwa_bullet.world.model import Box, World


def test_trajectory_length_and_posture_displacement():
    assert trajectory_length(np.array([[0, 0], [3, 4], [3, 5]])) == pytest.approx(6.0)
    assert trajectory_length(np.zeros((1, 2))) == 0.0
    # Wrapping: +170 deg -> -170 deg is a 20 deg turn, not 340.
    yaw = np.radians([0, 90, 170, -170, -90])
    assert posture_displacement(yaw) == pytest.approx(math.radians(90 + 80 + 20 + 80))


def test_body_clearance_measures_the_body_rectangle():
    world = World("w", "d", (0, 0, 0), (-1, 0), (Box((1.0, 0.0), (0.2, 2.0)),))
    d = body_clearance(world, np.array([[0.0, 0.0, 0.0], [0.0, 0.0, math.pi]]))
    assert d[0] == pytest.approx(0.9 - 0.237, abs=1e-9)  # front overhang 0.237 m
    assert d[1] == pytest.approx(0.9 - 0.150, abs=1e-9)  # facing away: rear overhang 0.150 m


def rows():
    def r(m, w, s, outcome, t=10.0, tl=3.0, pd=1.0):
        return dict(method=m, world=w, seed=s, outcome=outcome, time_s=t, tl_m=tl, pd_rad=pd)

    return [
        r("dwa1", "TS1", 0, "goal", 10.0, 3.0, 1.0),
        r("dwa1", "TS1", 1, "goal", 12.0, 3.2, 1.2),
        r("dwa2", "TS1", 0, "goal", 9.0, 3.5, 0.5),
        r("dwa2", "TS1", 1, "timeout", 60.0),
        r("dwa1", "TS2", 0, "collision", 5.0),
        r("dwa1", "TS2", 1, "collision", 6.0),
        r("dwa2", "TS2", 0, "timeout", 60.0),
        r("dwa2", "TS2", 1, "collision", 8.0),
    ]


def test_paper_table_marks_failures_partial_success_and_bold_best():
    table = paper_table(rows(), ["dwa1", "dwa2"], ["TS1", "TS2"])
    lines = table.strip().splitlines()
    assert lines[0].startswith("| Method | TS1 Time | TS1 TL | TS1 PD | TS2 Time")
    dwa1 = lines[2].split("|")
    dwa2 = lines[3].split("|")
    assert dwa1[2].strip() == "11.00" and dwa1[3].strip() == "**3.10**"
    assert dwa2[2].strip() == "**9.00** (1/2)" and dwa2[4].strip() == "**0.50**"
    assert [c.strip() for c in dwa1[5:8]] == ["C", "--", "--"]  # all collisions
    assert dwa2[5].strip() == "T"  # any timeout among failures
