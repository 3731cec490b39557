"""How an episode failed, read from its per-step log: one primary mode and every symptom.

Pure numpy over the arrays :func:`~d3dwa_bullet.evaluation.results.save_log` writes (true
and estimated pose, commands, chosen action, the planner's fallback flag), so a sweep's
failures can be sorted into kinds without rerunning anything. The symptoms, each with the
physical reason for its threshold (fixed here, before any sweep was classified):

===============  ==========================================================================
symptom          holds when
===============  ==========================================================================
drift            the estimate strays more than DRIFT_M (0.25 m, about the robot's half
                 width: enough to misjudge which gap the body fits) from the true pose
fallback storm   the planner finds no admissible motion on more than FALLBACK_SHARE (20 %)
                 of steps: the scan shows obstacles too close on every candidate arc, e.g.
                 spurious short returns
stall            the robot moves slower than STALL_MPS (2 cm/s) over more than STALL_SHARE
                 (30 %) of the episode
oscillation      the chosen action changes on more than SWITCH_SHARE (30 %) of steps, or the
                 turn command changes sign (|w| > 0.1 rad/s) more than FLIP_HZ (0.5) times
                 a second: the policy or the planner dithers between choices
===============  ==========================================================================

With a recovery layer (``--recovery``) the log marks its steps; :func:`recoveries` counts
the recoveries an episode started and those that led to progress: after the recovery the
estimated pose got farther than the progress radius (0.5 m) from where the recovery began,
before the next recovery began or the episode ended (or the episode reached the goal).

The primary mode of a failure is its outcome if it collided, else the first symptom in the
order above, else ``slow`` (moving, no symptom, but not arriving in time). Latency cannot
be read from a log; its share shows only as the profile the episode ran under.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

CONTROL_DT = 0.1
"""Control period of the logs, s."""
DRIFT_M = 0.25
FALLBACK_SHARE = 0.2
STALL_MPS = 0.02
STALL_SHARE = 0.3
SWITCH_SHARE = 0.3
FLIP_HZ = 0.5
TURNING = 0.1
"""|w| above which a turn command counts for sign flips, rad/s."""
SYMPTOMS = ("drift", "fallback storm", "stall", "oscillation")
MODES = ("collision", *SYMPTOMS, "slow")
"""Primary modes, in the order they are assigned."""


CIRCLING_RAD_S = 1.0
"""Mean turn rate over a failed episode (PD / time) above which it counts as circling, rad/s:
a full turn every 6.3 s or faster. A count beside the modes, not one of them, so no episode
changes mode: it was added after issue 22's sweeps showed progress-aware policies turning
circles for a whole episode, which the modes file under ``slow`` or ``oscillation``."""


def circling(pd_rad: float, time_s: float) -> bool:
    """Whether an episode's heading turned faster than CIRCLING_RAD_S on average."""
    return time_s > 0 and pd_rad / time_s > CIRCLING_RAD_S


PROGRESS_RADIUS = 0.5
"""Movement that counts as progress after a recovery, m (the progress checker's default)."""


def recoveries(log: Mapping[str, Any], radius: float = PROGRESS_RADIUS) -> tuple[int, int]:
    """(recoveries started, recoveries that led to progress) of one episode's log (0, 0 for
    a log without a ``recovery`` column: the paper's stack)."""
    codes = np.asarray(log.get("recovery", ()))
    if codes.size == 0:
        return 0, 0
    on = codes > 0
    starts = np.flatnonzero(on & ~np.concatenate(([False], on[:-1])))
    if starts.size == 0:
        return 0, 0
    x, y = np.asarray(log["est_x"]), np.asarray(log["est_y"])
    bounds = [*starts[1:], len(codes)]
    progress = 0
    for k, (i, stop) in enumerate(zip(starts, bounds, strict=True)):
        moved = np.hypot(x[i:stop] - x[i], y[i:stop] - y[i])
        last_one_won = k == len(starts) - 1 and str(log.get("outcome")) == "goal"
        progress += bool(moved.size and moved.max() > radius) or last_one_won
    return len(starts), progress


def symptoms(log: Mapping[str, Any]) -> dict[str, float]:
    """The measured quantity behind each symptom (not yet compared with a threshold):
    drift_m, fallback_share, stall_share, switch_share, flip_hz."""
    n = len(log["t"])
    if n == 0:
        return {"drift_m": 0.0, "fallback_share": 0.0, "stall_share": 0.0,
                "switch_share": 0.0, "flip_hz": 0.0}  # fmt: skip
    true_x, true_y = np.asarray(log["true_x"]), np.asarray(log["true_y"])
    error = np.hypot(np.asarray(log["est_x"]) - true_x[:n], np.asarray(log["est_y"]) - true_y[:n])
    speed = np.hypot(np.diff(true_x), np.diff(true_y)) / CONTROL_DT
    action = np.asarray(log["action"])
    w = np.asarray(log["w_cmd"])
    turning = np.sign(w[np.abs(w) > TURNING])
    flips = int(np.count_nonzero(np.diff(turning))) if turning.size > 1 else 0
    return {
        "drift_m": float(error.max()),
        "fallback_share": float(np.mean(np.asarray(log["fallback"]) > 0)),
        "stall_share": float(np.mean(speed < STALL_MPS)) if speed.size else 0.0,
        "switch_share": float(np.mean(action[1:] != action[:-1])) if n > 1 else 0.0,
        "flip_hz": flips / (n * CONTROL_DT),
    }


def present(measured: Mapping[str, float]) -> list[str]:
    """The symptoms whose quantity crosses its threshold, in SYMPTOMS order."""
    found = []
    if measured["drift_m"] > DRIFT_M:
        found.append("drift")
    if measured["fallback_share"] > FALLBACK_SHARE:
        found.append("fallback storm")
    if measured["stall_share"] > STALL_SHARE:
        found.append("stall")
    if measured["switch_share"] > SWITCH_SHARE or measured["flip_hz"] > FLIP_HZ:
        found.append("oscillation")
    return found


def primary_mode(outcome: str, found: list[str]) -> str:
    """The one mode a failure is counted under (module docstring)."""
    if outcome == "collision":
        return "collision"
    return found[0] if found else "slow"


def classify(log: Mapping[str, Any]) -> dict[str, Any]:
    """{"outcome", "mode", "symptoms": [...], **measured} of one episode's log."""
    outcome = str(log["outcome"])
    measured = symptoms(log)
    found = present(measured)
    mode = "goal" if outcome == "goal" else primary_mode(outcome, found)
    return {"outcome": outcome, "mode": mode, "symptoms": found, **measured}
