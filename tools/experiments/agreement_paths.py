"""Where a kinematic run and its PyBullet twin part: the agreement study's account of why outcomes differ.

Read by tools/experiments/kinematic_agreement.py. A pair is one episode (world, method, profile, episode
seed, layer) on both backends; both per-step logs sample the true pose at the same control instants
(10 Hz), so the paths are compared step by step:

- **parting time**: the first instant the two true positions are more than ``PART`` (0.10 m) apart
  (None: never within the shorter run);
- **first different action**: for a method whose action varies (a learned policy), the first control
  step at which the two chose a different (weights, horizon) action, and how far apart the paths were
  then (mm);
- **goal-time ratio**: PyBullet's episode time over the kinematic one's where both reached the goal.

``figure`` draws both trajectories of one pair side by side (the repository's trajectory figure).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from d3dwa_bullet.evaluation.jobs import row_log_path
from d3dwa_bullet.evaluation.plotting import trajectory_figure
from d3dwa_bullet.evaluation.results import load_log
from d3dwa_bullet.world.registry import load_world

PART = 0.10
"""Paths more than this far apart (m) have parted."""
FIXED = ("dwa3",)
"""Methods whose action never varies: no first different action to find."""


def parting(kin: dict, ref: dict) -> dict:
    """{"part_s": first time (s) the true paths are > PART apart or None, "action_s": first time the
    actions differ or None, "action_gap_mm": the paths' distance then (mm) or None} of two logs (each
    with t (T,), true_x and true_y (T + 1,), action (T,))."""
    n = min(len(kin["true_x"]), len(ref["true_x"]))
    gap = np.hypot(
        np.asarray(kin["true_x"][:n]) - np.asarray(ref["true_x"][:n]),
        np.asarray(kin["true_y"][:n]) - np.asarray(ref["true_y"][:n]),
    )
    t = np.asarray(kin["t"], dtype=float)
    times = np.append(t, t[-1] + (t[1] - t[0] if len(t) > 1 else 0.1))[
        :n
    ]  # (n,): pose i is at times[i]
    out: dict = {"part_s": None, "action_s": None, "action_gap_mm": None}
    apart = np.flatnonzero(gap > PART)
    if apart.size:
        out["part_s"] = float(times[apart[0]])
    m = min(len(kin["action"]), len(ref["action"]))
    differ = np.flatnonzero(np.asarray(kin["action"][:m]) != np.asarray(ref["action"][:m]))
    if differ.size:
        out["action_s"] = float(times[differ[0]])
        out["action_gap_mm"] = float(1000.0 * gap[differ[0]])
    return out


def _median(xs: Sequence[float]) -> str:
    return "-" if not xs else f"{np.median(xs):.3g}"


def parting_lines(kin: Path, ref: Path, pairs: Sequence[tuple[dict, dict]]) -> list[str]:
    """Summary lines of where the pairs' paths part, equal and differing outcomes apart, the learned
    methods' first different action, and the goal-time ratio (pairs whose logs are missing are skipped)."""
    parts: dict[bool, list] = {True: [], False: []}
    actions, ratios = [], []
    for k, r in pairs:
        pk, pr = row_log_path(kin, k), row_log_path(ref, r)
        if not (pk.is_file() and pr.is_file()):
            continue
        p = parting(load_log(pk), load_log(pr))
        parts[k["outcome"] == r["outcome"]].append(p["part_s"])
        if k["method"] not in FIXED and p["action_s"] is not None:
            actions.append((p["action_s"], p["action_gap_mm"]))
        if k["outcome"] == r["outcome"] == "goal":
            ratios.append(float(r["time_s"]) / float(k["time_s"]))
    lines = []
    for same, name in ((True, "equal outcomes"), (False, "different outcomes")):
        xs = [x for x in parts[same] if x is not None]
        lines.append(f"  {name}: {len(xs)} of {len(parts[same])} pairs' paths part by "
                     f"{100 * PART:.0f} cm, at {_median(xs)} s (median)")  # fmt: skip
    if actions:
        at, gap = _median([a for a, _ in actions]), _median([g for _, g in actions])
        lines.append(f"  methods that choose actions: the first different action at {at} s "
                     f"(median, {len(actions)} pairs), the paths then {gap} mm apart")  # fmt: skip
    if ratios:
        q = np.percentile(ratios, [25, 50, 75])
        lines.append(f"  both at the goal ({len(ratios)} pairs): PyBullet's time / the "
                     f"kinematic one's {q[1]:.3f} median [{q[0]:.3f}, {q[2]:.3f}] quartiles")  # fmt: skip
    return lines


def figure(kin: Path, ref: Path, pair: tuple[dict, dict], path: Path) -> None:
    """Both trajectories of one episode, kinematic left, PyBullet right."""
    runs = []
    for out, row, label in ((kin, pair[0], "kinematic"), (ref, pair[1], "PyBullet")):
        log = load_log(row_log_path(out, row))
        t = list(log["t"]) + [row["time_s"]]
        runs.append({"label": f"{row['method']} {row['noise']} {label}", "outcome": row["outcome"], "t": t,
                     "x": log["true_x"], "y": log["true_y"], "tau": list(log["tau"]) + list(log["tau"][-1:]),
                     "recovery": log.get("recovery")})  # fmt: skip
    world = load_world(pair[0]["world"])
    trajectory_figure(
        world, runs, path, title=f"{world.name}: {pair[0]['method']}, {pair[0]['noise']}"
    )
