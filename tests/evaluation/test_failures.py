"""Failure modes from per-step logs: each symptom from a log built to show it, and the
order that picks one primary mode."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.evaluation.failures import classify, primary_mode, recoveries, symptoms


def log(n=100, speed=0.2, outcome="timeout", **over):
    """A log of n steps driving straight at speed (m/s), estimate exact, no fallback."""
    x = np.arange(n + 1) * speed * 0.1
    base = {
        "outcome": outcome, "t": np.arange(n) * 0.1,
        "true_x": x, "true_y": np.zeros(n + 1), "est_x": x[:n].copy(), "est_y": np.zeros(n),
        "action": np.zeros(n, dtype=int), "w_cmd": np.zeros(n), "fallback": np.zeros(n),
    }  # fmt: skip
    return base | over


def test_a_moving_robot_without_symptoms_is_slow():
    found = classify(log())
    assert found["mode"] == "slow" and found["symptoms"] == []
    assert found["stall_share"] == 0.0 and found["drift_m"] == 0.0


def test_each_symptom_from_a_log_that_shows_it():
    assert classify(log(speed=0.0))["mode"] == "stall"
    assert classify(log(speed=0.01))["stall_share"] == 1.0  # 1 cm/s is below 2 cm/s
    est = log()["est_x"] + np.linspace(0, 0.4, 100)  # the estimate walks 0.4 m off
    assert classify(log(est_x=est))["mode"] == "drift"
    assert classify(log(est_x=log()["est_x"] + 0.2))["symptoms"] == []  # 0.2 m is within 0.25
    fallback = (np.arange(100) % 4 == 0).astype(float)  # 25 % of steps
    assert classify(log(fallback=fallback))["mode"] == "fallback storm"
    actions = np.arange(100) % 2  # a new action every step
    assert classify(log(action=actions))["mode"] == "oscillation"
    w = np.where(np.arange(100) % 10 < 5, 0.5, -0.5)  # turn sign flips every 0.5 s: ~2 Hz
    measured = symptoms(log(w_cmd=w))
    assert measured["flip_hz"] == pytest.approx(19 / 10.0)
    assert classify(log(w_cmd=w))["mode"] == "oscillation"


def test_the_primary_mode_is_the_first_symptom_and_a_collision_is_a_collision():
    both = log(speed=0.0, action=np.arange(100) % 2)
    found = classify(both)
    assert found["symptoms"] == ["stall", "oscillation"] and found["mode"] == "stall"
    assert classify(dict(both, outcome="collision"))["mode"] == "collision"
    assert classify(dict(both, outcome="goal"))["mode"] == "goal"
    assert primary_mode("timeout", []) == "slow"


def test_recoveries_count_starts_and_those_followed_by_progress():
    codes = np.array([0, 0, 1, 1, 0, 0, 0, 2, 2, 0, 0])
    x = np.array([0, 0, 0, 0, 0.1, 0.3, 0.7, 0.7, 0.6, 0.6, 0.65])
    log = {"recovery": codes, "est_x": x, "est_y": np.zeros_like(x), "outcome": "timeout"}
    # the spin at step 2 is followed by 0.7 m of travel before the back-up at step 7; the
    # back-up by 0.1 m at most, and the episode timed out
    assert recoveries(log) == (2, 1)
    assert recoveries(log | {"outcome": "goal"}) == (2, 2)  # the last one led to the goal
    assert recoveries(log, radius=0.8) == (2, 0)
    assert recoveries({"est_x": x, "est_y": x, "outcome": "goal"}) == (0, 0)  # paper track
    assert recoveries(log | {"recovery": np.zeros(11, dtype=int)}) == (0, 0)
