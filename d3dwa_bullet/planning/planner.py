"""The Dynamic Window Approach (docs/design/planner.md#planner), as one pure, vectorised function.

Everything is in base_link at planning time: the robot sits at the origin facing +x,
``points`` are valid scan returns and ``goal`` is the goal, both in the body frame.

Design choices the paper leaves open (docs/design/planner.md#footprint and after):

* Footprint: three circles of radius r = 0.15 m on the body axis (see
  :class:`~d3dwa_bullet.params.Footprint`) cover Kachaka's whole body. The clearance of a
  trajectory is the smallest distance from any circle centre, at any rollout step
  (0.1 s .. tau), to any scan point, capped at ``clearance_cap``. Admissible means
  clearance > r + m, the paper's margin semantics.
* No separate braking condition: a trajectory is admissible only if it is clear for the
  whole horizon tau >= 2 s, far longer than the stopping time v_max / a_max = 0.2 s, so
  the classic v <= sqrt(2 * dist * a_max) test can never reject an admissible sample.
* Clearance lives on a lattice, like a ROS costmap: scan points and circle centres are
  snapped to cells of ``grid_resolution`` (cell (i, j) is centred at (i, j) * res in
  base_link) and clearance is the Euclidean distance between cell centres, computed for all
  samples at once with OpenCV's exact distance transform; a small numba kernel reads the
  field along every rollout (vectorising that read in numpy costs ~10 passes over 120k
  cells, more than the whole planning budget). The sample geometry and the scoring are
  compiled the same way (``_geometry``, ``_score``); tests hold them to the closed-form
  arcs and to the brute-force reference's normalisation and selection. Against continuous
  geometry the
  snapping costs at most res / sqrt(2) per end (1.4 cm at 2 cm cells); ``scripts/
  bench_planner.py`` reports the measured figure.
* Fallback when nothing is admissible: the sample with the largest clearance over its whole
  horizon (ties to the slowest), i.e. stop, rotate in place or creep, whichever keeps the
  body farthest from what the lidar sees. Blindly turning toward the goal, tried first,
  swung the body's front corner into the obstacle that had boxed the robot in (TS3, TS4).
  ``PlanResult.fallback`` flags it.
* Ties in J go to the lowest flat sample index (v-major, then w), like ``numpy.argmax``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numba
import numpy as np

from d3dwa_bullet.params import PlannerParams
from d3dwa_bullet.planning.actions import PlannerAction  # re-exported: its old home
from d3dwa_bullet.sim.scan import check_points

#: Admissible means clearance > r + m + TIE_TOLERANCE. Lattice clearances are sqrt(n) * res,
#: so a trajectory exactly 10 cells (= r + m) away is common; rounding (float32 field vs
#: float64 maths) must not decide it. The next lattice value above 0.2 m is 0.201 m.
TIE_TOLERANCE = 1e-6


class PlanResult(NamedTuple):
    """The command and the diagnostics of one planning step. S = n_v * n_w samples."""

    v: float
    """Commanded translational velocity, m/s."""
    w: float
    """Commanded angular velocity, rad/s."""
    index: int  # type: ignore[assignment]  # shadows tuple.index; the public name stays
    """Chosen flat sample index, or -1 on fallback."""
    fallback: bool
    """True when no sample was admissible."""
    samples: np.ndarray
    """(S, 2) float64 sampled (v, w)."""
    progress: np.ndarray
    """(S,) raw progress criterion, m."""
    clearance: np.ndarray
    """(S,) raw clearance criterion, m (capped)."""
    speed: np.ndarray
    """(S,) raw speed criterion, m/s."""
    admissible: np.ndarray
    """(S,) bool."""
    scores: np.ndarray
    """(S,) J over normalised criteria; -inf where not admissible."""


def dynamic_window(
    v0: float, w0: float, params: PlannerParams
) -> tuple[float, float, float, float]:
    """(v_lo, v_hi, w_lo, w_hi): velocities reachable within one control period, in limits."""
    lim, t = params.limits, params.control_period
    v_lo = max(0.0, v0 - lim.a_max * t)
    v_hi = min(lim.v_max, v0 + lim.a_max * t)
    w_lo = max(-lim.w_max, w0 - lim.alpha_max * t)
    w_hi = min(lim.w_max, w0 + lim.alpha_max * t)
    # A state outside the limits (e.g. noisy estimate) still gets a non-empty window.
    v_lo, v_hi = min(v_lo, v_hi), max(v_lo, v_hi)
    w_lo, w_hi = min(w_lo, w_hi), max(w_lo, w_hi)
    return v_lo, min(max(v_hi, 0.0), lim.v_max), w_lo, w_hi


def sample_window(v0: float, w0: float, params: PlannerParams) -> tuple[np.ndarray, np.ndarray]:
    """The n_v and n_w grid values spanning the dynamic window: (n_v,), (n_w,) float64."""
    v_lo, v_hi, w_lo, w_hi = dynamic_window(v0, w0, params)
    return np.linspace(v_lo, v_hi, params.n_v), np.linspace(w_lo, w_hi, params.n_w)


def rollout_steps(tau: float, dt: float) -> np.ndarray:
    """Rollout times dt, 2 dt, ..., tau: (n,) float64, s."""
    n = max(1, int(round(tau / dt)))
    return dt * np.arange(1, n + 1)


@numba.njit(cache=True, nogil=True)
def _sample_clearance(dist, width, vs, ux, uy, off_x, off_y, stop_below, out):  # pragma: no cover
    """Per sample, the smallest field value over its rollout steps and circles.

    dist: (H*W,) float32 field; ux, uy: (n_w, n) unit arcs in cells; off_x, off_y:
    (n_w, n, C) circle offsets in cells, shifted into the field. A sample whose running
    minimum drops to stop_below is inadmissible whatever follows, so its scan stops there
    (its reported clearance is then an upper bound <= stop_below). JIT-compiled: this is
    the one hot loop of the planner, 20 x 40 x 50 x 3 lookups per call.
    """
    n_w, n_t, n_c = off_x.shape
    for i in range(vs.shape[0]):
        v = vs[i]
        for j in range(n_w):
            best = np.inf
            for k in range(n_t):
                bx = v * ux[j, k]
                by = v * uy[j, k]
                for c in range(n_c):
                    d = dist[int(by + off_y[j, k, c]) * width + int(bx + off_x[j, k, c])]
                    if d < best:
                        best = d
                if best <= stop_below:
                    break
            out[i * n_w + j] = best


@numba.njit(cache=True, nogil=True)
def _geometry(vs, ws, t, cx, gx, gy, res, reach):  # pragma: no cover
    """Everything the planner needs from the sample grid before the distance field.

    Returns the unit arcs ux, uy (n_w, n): the position after time t at unit speed and turn
    rate w (sin(wt)/w, (1-cos(wt))/w; (t, 0) when straight), so v * (ux, uy) serves every
    v; the circle-centre
    offsets off_x, off_y (n_w, n, C), the progress criterion (n_v * n_w,) and the lattice
    box (i_min, j_min, i_max, j_max) holding every circle centre of every sample, grown by
    ``reach`` cells. Positions are linear in v, so v's extremes bound them. One compiled
    loop: in numpy these are ~30 small array operations, more time than the clearance read.
    """
    n_v, n_w, n_t, n_c = vs.shape[0], ws.shape[0], t.shape[0], cx.shape[0]
    ux = np.empty((n_w, n_t))
    uy = np.empty((n_w, n_t))
    off_x = np.empty((n_w, n_t, n_c))
    off_y = np.empty((n_w, n_t, n_c))
    lo_x, lo_y, hi_x, hi_y = np.inf, np.inf, -np.inf, -np.inf
    v_lo, v_hi = vs[0], vs[n_v - 1]
    for j in range(n_w):
        w = ws[j]
        turning = abs(w) > 1e-9
        for k in range(n_t):
            theta = w * t[k]
            c, s = math.cos(theta), math.sin(theta)
            if turning:
                x, y = s / w, (1.0 - c) / w
            else:
                x, y = t[k], 0.0
            ux[j, k], uy[j, k] = x, y
            for m in range(n_c):
                ox, oy = c * cx[m], s * cx[m]
                off_x[j, k, m], off_y[j, k, m] = ox, oy
                for v in (v_lo, v_hi):
                    px, py = v * x + ox, v * y + oy
                    lo_x, hi_x = min(lo_x, px), max(hi_x, px)
                    lo_y, hi_y = min(lo_y, py), max(hi_y, py)
    d0 = math.hypot(gx, gy)
    progress = np.empty(n_v * n_w)
    for i in range(n_v):
        for j in range(n_w):
            ex, ey = vs[i] * ux[j, n_t - 1], vs[i] * uy[j, n_t - 1]
            progress[i * n_w + j] = d0 - math.hypot(gx - ex, gy - ey)
    box = (
        int(math.floor(lo_x / res)) - reach,
        int(math.floor(lo_y / res)) - reach,
        int(math.ceil(hi_x / res)) + reach,
        int(math.ceil(hi_y / res)) + reach,
    )
    return ux, uy, off_x, off_y, progress, box


@numba.njit(cache=True, nogil=True)
def _score(progress, clearance, speed, admissible, wp, wc, ws, scores):  # pragma: no cover
    """J = wp*c_p + wc*c_c + ws*c_s over criteria min-max normalised across the admissible
    set (a constant criterion gives 0). Fills scores (-inf where not admissible) and returns
    the argmax (first of equals, -1 when nothing is admissible)."""
    n = progress.shape[0]
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    any_ok = False
    for i in range(n):
        if admissible[i]:
            any_ok = True
            for q, val in enumerate((progress[i], clearance[i], speed[i])):
                lo[q], hi[q] = min(lo[q], val), max(hi[q], val)
    best, best_score = -1, -np.inf
    for i in range(n):
        if not admissible[i]:
            scores[i] = -np.inf
            continue
        total = 0.0
        for q, (val, weight) in enumerate(((progress[i], wp), (clearance[i], wc), (speed[i], ws))):
            if hi[q] > lo[q]:
                total += weight * ((val - lo[q]) / (hi[q] - lo[q]))
        scores[i] = total
        if total > best_score:
            best, best_score = i, total
    return best if any_ok else -1


class _DistanceField(NamedTuple):
    dist: np.ndarray  # (H*W,) float32, metres between cell centres and nearest occupied cell
    i0: int  # lattice index of column 0
    j0: int  # lattice index of row 0
    width: int


def lattice(xy: np.ndarray, res: float) -> np.ndarray:
    """Lattice cell index of coordinates: round(xy / res), same shape, intp."""
    return np.floor(xy / res + 0.5).astype(np.intp)


def _distance_field(
    cells: np.ndarray, box: tuple[int, int, int, int], res: float
) -> _DistanceField:
    """Exact Euclidean distance field over lattice box (i_min, j_min, i_max, j_max).

    cells: (M, 2) lattice indices of occupied cells, all inside box.
    """
    i_min, j_min, i_max, j_max = box
    width, height = i_max - i_min + 1, j_max - j_min + 1
    img = np.ones((height, width), np.uint8)
    img[cells[:, 1] - j_min, cells[:, 0] - i_min] = 0
    dist = cv2.distanceTransform(img, cv2.DIST_L2, cv2.DIST_MASK_PRECISE).ravel()
    # OpenCV's result can differ by one float32 ulp from call to call on the same image (its
    # vectorised paths depend on buffer alignment), which was enough to flip a tie between
    # samples and change a noisy episode. Between cell centres the squared distance is an
    # integer, recovered exactly by rounding (error << 0.5 for fields under ~2,000 cells
    # across); its correctly rounded square root is the same on every call.
    np.multiply(dist, dist, out=dist)
    np.rint(dist, out=dist)
    np.sqrt(dist, out=dist)
    np.multiply(dist, np.float32(res), out=dist)
    return _DistanceField(dist, i_min, j_min, width)


def plan(
    velocity: tuple[float, float],
    points: np.ndarray,
    goal: np.ndarray | tuple[float, float],
    action: PlannerAction,
    params: PlannerParams = PlannerParams(),
) -> PlanResult:
    """One DWA planning step.

    velocity: current (v, w), m/s and rad/s.
    points: (M, 2) float64 valid scan returns, m, base_link frame.
    goal: (2,) goal position, m, base_link frame.
    action: weights (wp, wc, ws) and horizon tau (s).
    """
    pts = check_points(points)
    v0, w0 = float(velocity[0]), float(velocity[1])
    gx, gy = float(goal[0]), float(goal[1])
    vs, ws = sample_window(v0, w0, params)
    t = rollout_steps(action.tau, params.dt)
    cx = np.asarray(params.footprint.centers_x, dtype=np.float64)
    res = params.grid_resolution
    cap = params.clearance_cap
    reach = int(math.ceil(cap / res)) + 1
    # Unit arcs, circle offsets (n_w, n, C), progress and the lattice box of every circle
    # centre (plus reach) in one compiled pass.
    ux, uy, off_x, off_y, progress, box = _geometry(vs, ws, t, cx, gx, gy, res, reach)
    n_s = len(vs) * len(ws)
    samples = np.empty((n_s, 2))
    samples[:, 0] = np.repeat(vs, len(ws))
    samples[:, 1] = np.tile(ws, len(vs))
    speed = np.abs(samples[:, 0])

    cells = lattice(pts, res)
    inside = (
        (cells[:, 0] >= box[0])
        & (cells[:, 1] >= box[1])
        & (cells[:, 0] <= box[2])
        & (cells[:, 1] <= box[3])
    )
    field = None
    if not inside.any():
        clearance = np.full(n_s, cap)
    else:
        cells = cells[inside]
        # Crop the field to the circle centres plus the points that can reach them.
        box = (
            min(box[0] + reach, int(cells[:, 0].min())),
            min(box[1] + reach, int(cells[:, 1].min())),
            max(box[2] - reach, int(cells[:, 0].max())),
            max(box[3] - reach, int(cells[:, 1].max())),
        )
        field = _distance_field(cells, box, res)
        inv = 1.0 / res
        tables = (
            vs,
            ux * inv,
            uy * inv,
            off_x * inv - field.i0 + 0.5,
            off_y * inv - field.j0 + 0.5,
        )
        clearance = np.empty(n_s)
        _sample_clearance(
            field.dist, field.width, *tables, params.admissible_clearance + TIE_TOLERANCE, clearance
        )
        np.minimum(clearance, cap, out=clearance)

    admissible = clearance > params.admissible_clearance + TIE_TOLERANCE
    scores = np.empty(n_s)
    best = _score(progress, clearance, speed, admissible, action.wp, action.wc, action.ws, scores)
    if best >= 0:
        v_cmd, w_cmd, fallback = float(samples[best, 0]), float(samples[best, 1]), False
    else:
        # Nothing is admissible: take the least-bad motion, the sample that stays farthest
        # from every scan point over its whole horizon (the early exit above left only
        # upper bounds, so those are recomputed in full). Ties go to the slowest sample.
        full = np.empty(n_s)
        _sample_clearance(field.dist, field.width, *tables, -np.inf, full)  # type: ignore[union-attr]
        safest = int(np.argmax(full))
        v_cmd, w_cmd, fallback = float(samples[safest, 0]), float(samples[safest, 1]), True
    return PlanResult(
        v=v_cmd,
        w=w_cmd,
        index=best,
        fallback=fallback,
        samples=samples,
        progress=progress,
        clearance=clearance,
        speed=speed,
        admissible=admissible,
        scores=scores,
    )
