"""The carrot a global plan's follower drives toward (docs/design/global-plan.md#replanning-and-the-carrot).

Pure maths (numpy, scikit-image; no simulator). Two rules, by name (``global_plan_params.CARROTS``):

* ``along``: ``lookahead`` metres along the path from its point nearest the robot (the goal once
  less remains). Round a sharp turn this point can lie across the corner, so the straight line
  to it crosses the obstacle the path goes round.
* ``sight``: the same point, unless the straight segment from the robot to some path point before
  it crosses a lethal cell of the costmap the path was planned on; then the last path point
  before the first such one. The carrot is thus the end of the longest stretch of the path ahead,
  at most ``lookahead`` long, every point of which the robot sees in a straight line through
  passable cells (a stretch, not the farthest visible point: a point seen again past an
  obstacle does not count). Cells within the robot's own r + m plus a cell are not checked (the
  robot may stand in a lethal cell's edge; the blocked-path test ignores them alike). When not
  even the first path point ahead is in sight the carrot is that point.

Regulated Pure Pursuit (Nav2) shortens its lookahead on curvature; ``sight`` shortens it on what
the costmap says is in the way, which is what stalls the DWA (its end-point progress toward a
carrot across a corner points into the corner).
"""

from __future__ import annotations

import numpy as np
from skimage.draw import line


def point_at(path: np.ndarray, arc: np.ndarray, s: float) -> np.ndarray:
    """(2,) m: the point of path (K, 2) m at arc length s (m; arc (K,) the cumulative length,
    arc[0] = 0), clipped to its ends."""
    if s >= arc[-1]:
        return path[-1].copy()
    m = max(int(np.searchsorted(arc, s)), 1)
    f = (s - arc[m - 1]) / max(arc[m] - arc[m - 1], 1e-12)
    return path[m - 1] + f * (path[m] - path[m - 1])


def in_sight(
    lethal: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    pose: tuple[float, ...],
    point: np.ndarray,
    ignore: float,
) -> bool:
    """Does the straight segment from pose (x, y, ...) to point (2,) m cross no cell of lethal
    ((ny, nx) bool, cell (i, j) centred at origin + (j, i) * resolution, m) farther than
    ignore (m) from the pose? Cells are those of skimage.draw.line between the two end cells;
    a cell off the grid counts as passable (the costmap's unknown is free)."""
    j0, i0 = (round((pose[0] - origin[0]) / resolution), round((pose[1] - origin[1]) / resolution))
    j1, i1 = (
        round((point[0] - origin[0]) / resolution),
        round((point[1] - origin[1]) / resolution),
    )
    rr, cc = line(int(i0), int(j0), int(i1), int(j1))
    ny, nx = lethal.shape
    on = (rr >= 0) & (rr < ny) & (cc >= 0) & (cc < nx)
    rr, cc = rr[on], cc[on]
    far = (
        np.hypot(cc * resolution + origin[0] - pose[0], rr * resolution + origin[1] - pose[1])
        > ignore
    )
    return not bool(lethal[rr[far], cc[far]].any())


def carrot_point(
    rule: str,
    path: np.ndarray,
    arc: np.ndarray,
    pose: tuple[float, ...],
    lookahead: float,
    lethal: np.ndarray | None = None,
    origin: tuple[float, float] = (0.0, 0.0),
    resolution: float = 1.0,
    ignore: float = 0.0,
) -> tuple[np.ndarray, float]:
    """((2,) carrot m, path length left from pose to the path's end m) by rule (``CARROTS``) on path
    (K >= 2, 2) m with arc (K,) its cumulative length. ``sight`` reads lethal ((ny, nx) bool, the
    costmap's lethal cells, with origin and resolution m; None: nothing lethal, the ``along``
    carrot) and ignores cells within ignore m of the pose."""
    d = np.hypot(path[:, 0] - pose[0], path[:, 1] - pose[1])
    k = int(np.argmin(d))
    left = float(d[k] + arc[-1] - arc[k])
    target = arc[k] + lookahead
    ahead = point_at(path, arc, target)
    if rule == "along" or lethal is None:
        return ahead, left
    stop = int(np.searchsorted(arc, target))  # the path's points before it lie at arc < target
    candidates = [path[i] for i in range(k + 1, min(stop, len(path)))] + [ahead]
    chosen = candidates[0]
    for point in candidates:
        if not in_sight(lethal, origin, resolution, pose, point, ignore):
            break
        chosen = point
    return np.asarray(chosen, dtype=np.float64), left
