"""Brute-force DWA, written for clarity, used only by tests to check planner.plan.

It loops over samples and rollout steps, integrates each arc step by step, and measures
clearance exactly against every scan point: no distance field, no shared tables.
"""

from __future__ import annotations

import math

import numpy as np

from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.planner import TIE_TOLERANCE, PlannerAction, dynamic_window


def normalise(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Min-max normalise values to [0, 1] across mask; a constant criterion gives 0."""
    out = np.zeros_like(values)
    if mask.any():
        sel = values[mask]
        if sel.max() > sel.min():
            out[mask] = (sel - sel.min()) / (sel.max() - sel.min())
    return out


def select(progress, clearance, speed, admissible, action: PlannerAction):
    """Scores J over the admissible set (-inf elsewhere) and the first argmax (-1 if none)."""
    scores = (
        action.wp * normalise(progress, admissible)
        + action.wc * normalise(clearance, admissible)
        + action.ws * normalise(speed, admissible)
    )
    best, best_score = -1, -math.inf
    for i in range(len(scores)):
        if admissible[i] and scores[i] > best_score:
            best, best_score = i, scores[i]
    return np.where(admissible, scores, -np.inf), best


def reference_plan(
    velocity, points, goal, action: PlannerAction, params: PlannerParams = PlannerParams()
):
    """Returns (v, w, index, clearance (S,), admissible (S,))."""
    v_lo, v_hi, w_lo, w_hi = dynamic_window(velocity[0], velocity[1], params)
    vs = [v_lo + (v_hi - v_lo) * i / (params.n_v - 1) for i in range(params.n_v)]
    ws = [w_lo + (w_hi - w_lo) * j / (params.n_w - 1) for j in range(params.n_w)]
    n_steps = max(1, int(round(action.tau / params.dt)))
    res = params.grid_resolution
    # Same lattice semantics as the planner: snap points and circle centres to cell centres.
    pts = np.floor(np.asarray(points, dtype=float) / res + 0.5) * res
    rows = []
    for v in vs:
        for w in ws:
            x = y = th = 0.0
            clear = params.clearance_cap
            for _ in range(n_steps):
                if abs(w) < 1e-12:
                    x += v * params.dt * math.cos(th)
                    y += v * params.dt * math.sin(th)
                else:
                    x += v / w * (math.sin(th + w * params.dt) - math.sin(th))
                    y -= v / w * (math.cos(th + w * params.dt) - math.cos(th))
                th += w * params.dt
                for c in params.footprint.centers_x:
                    px = math.floor((x + c * math.cos(th)) / res + 0.5) * res
                    py = math.floor((y + c * math.sin(th)) / res + 0.5) * res
                    if len(pts):
                        clear = min(clear, float(np.min(np.hypot(pts[:, 0] - px, pts[:, 1] - py))))
            progress = math.hypot(goal[0], goal[1]) - math.hypot(goal[0] - x, goal[1] - y)
            rows.append((v, w, progress, clear, abs(v)))
    arr = np.array(rows)
    admissible = arr[:, 3] > params.admissible_clearance + TIE_TOLERANCE
    _, best = select(arr[:, 2], arr[:, 3], arr[:, 4], admissible, action)
    if best < 0:
        return None, None, -1, arr[:, 3], admissible
    return arr[best, 0], arr[best, 1], best, arr[:, 3], admissible
