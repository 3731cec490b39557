"""The world as the kinematic backend sees it: a plane of boxes and circles, a 2D ray cast and
a footprint contact test, compiled with numba (docs/design/backends.md).

Obstacles are packed once per world into one (N, 7) float64 array, a row each:
``kind (0 box, 1 cylinder), cx, cy, a, b, yaw, height`` with ``a, b`` the box's half sizes
(m) or the cylinder's radius twice. A cylinder is cast as a true circle, where PyBullet casts
against its 48-sided prism (:data:`~d3dwa_bullet.world.model.CYLINDER_SEGMENTS`): ranges differ
by at most ``r (1 - cos(pi / 48))``, 0.16 mm for BARN's 7.5 cm pillars.

The ray cast visits, for each obstacle, only the beams whose directions pass within the
obstacle's bounding circle, so its cost grows with the number of obstacles plus the number of
hits, not with their product.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.model import Box, Cylinder, World

BOX, CYLINDER = 0.0, 1.0
"""Kind codes of the packed obstacle rows."""
COLUMNS = 7
"""Columns of a packed row: kind, cx, cy, a, b, yaw, height."""


def pack_obstacles(world: World) -> np.ndarray:
    """The world's obstacles as (N, 7) float64 rows (module docstring). ConfigError naming the
    world and the obstacle for anything but a Box or a Cylinder: no other shape can be cast."""
    rows = np.zeros((len(world.obstacles), COLUMNS))
    for i, ob in enumerate(world.obstacles):
        if isinstance(ob, Box):
            rows[i] = (BOX, ob.center[0], ob.center[1], 0.5 * ob.size[0], 0.5 * ob.size[1], ob.yaw,
                       ob.height)  # fmt: skip
        elif isinstance(ob, Cylinder):
            rows[i] = (CYLINDER, ob.center[0], ob.center[1], ob.radius, ob.radius, 0.0, ob.height)
        else:
            raise ConfigError(
                f"world {world.name!r}: obstacle {i} is a {type(ob).__name__}; the kinematic "
                "backend casts boxes and cylinders only (use --backend pybullet)"
            )
    return rows


@numba.njit(cache=True, nogil=True)
def _ray_hit(row: np.ndarray, ox: float, oy: float, dx: float, dy: float) -> float:
    """Distance along the unit ray (o, d) to the obstacle's wall, m; inf if it misses. A ray that
    starts inside meets the wall on its way out, as a ray meets a mesh's back face."""
    cx, cy = row[1], row[2]
    if row[0] == CYLINDER:
        r = row[3]
        fx, fy = ox - cx, oy - cy
        b = fx * dx + fy * dy
        disc = b * b - (fx * fx + fy * fy - r * r)
        if disc < 0.0:
            return np.inf
        root = math.sqrt(disc)
        t = -b - root
        if t < 0.0:
            t = -b + root
        return t if t >= 0.0 else np.inf
    c, s = math.cos(row[5]), math.sin(row[5])
    # the ray in the box's frame
    px, py = c * (ox - cx) + s * (oy - cy), -s * (ox - cx) + c * (oy - cy)
    qx, qy = c * dx + s * dy, -s * dx + c * dy
    t0, t1 = -np.inf, np.inf
    for p, q, h in ((px, qx, row[3]), (py, qy, row[4])):
        if abs(q) < 1e-15:
            if abs(p) > h:
                return np.inf
            continue
        a, b = (-h - p) / q, (h - p) / q
        if a > b:
            a, b = b, a
        t0, t1 = max(t0, a), min(t1, b)
        if t0 > t1:
            return np.inf
    if t0 >= 0.0:
        return t0
    return t1 if t1 >= 0.0 else np.inf


@numba.njit(cache=True, nogil=True)
def cast_rays(
    rows: np.ndarray, ox: float, oy: float, yaw: float, z: float,
    angle_min: float, increment: float, beams: int, range_max: float,
) -> np.ndarray:  # fmt: skip
    """True ranges of a planar lidar at (ox, oy) m heading yaw rad, z m above the floor: (beams,)
    float64, m, +inf where no wall lies within range_max. Beam i points at ``yaw + angle_min + i
    increment``. An obstacle no taller than z is under the beams and never hit."""
    out = np.full(beams, np.inf)
    two_pi = 2.0 * math.pi
    for k in range(rows.shape[0]):
        row = rows[k]
        if row[6] <= z:
            continue
        bound = row[3] if row[0] == CYLINDER else math.hypot(row[3], row[4])
        ddx, ddy = row[1] - ox, row[2] - oy
        d = math.hypot(ddx, ddy)
        if d - bound > range_max:
            continue
        if d <= bound:  # inside the bounding circle: every beam may meet it
            lo, hi, turns = 0, beams - 1, 0
        else:
            half = math.asin(bound / d)
            centre = math.atan2(ddy, ddx) - yaw - angle_min
            centre -= two_pi * math.floor(centre / two_pi)  # in [0, 2 pi)
            lo = int(math.ceil((centre - half) / increment)) - 1  # a beam's margin either side
            hi = int(math.floor((centre + half) / increment)) + 1
            turns = 1  # the span a turn either way too: a field of view of 2 pi wraps
        for turn in range(-turns, turns + 1):
            off = int(round(turn * two_pi / increment))
            for i in range(max(lo + off, 0), min(hi + off, beams - 1) + 1):
                th = yaw + angle_min + i * increment
                t = _ray_hit(row, ox, oy, math.cos(th), math.sin(th))
                if t < out[i]:
                    out[i] = t
    for i in range(beams):
        if out[i] >= range_max:
            out[i] = np.inf
    return out


@numba.njit(cache=True, nogil=True)
def _box_touches(row: np.ndarray, bx: float, by: float, byaw: float, hx: float, hy: float,
                 margin: float) -> bool:  # fmt: skip
    """Does the body rectangle (centre (bx, by), yaw byaw, half sizes hx, hy) come within margin
    of the obstacle? Separating axes of both rectangles, or the circle's nearest point."""
    c, s = math.cos(byaw), math.sin(byaw)
    if row[0] == CYLINDER:
        px, py = c * (row[1] - bx) + s * (row[2] - by), -s * (row[1] - bx) + c * (row[2] - by)
        qx, qy = min(max(px, -hx), hx), min(max(py, -hy), hy)
        return math.hypot(px - qx, py - qy) <= row[3] + margin
    oc, os_ = math.cos(row[5]), math.sin(row[5])
    axes = ((c, s), (-s, c), (oc, os_), (-os_, oc))
    ddx, ddy = row[1] - bx, row[2] - by
    for ax, ay in axes:
        body = hx * abs(c * ax + s * ay) + hy * abs(-s * ax + c * ay)
        ob = row[3] * abs(oc * ax + os_ * ay) + row[4] * abs(-os_ * ax + oc * ay)
        if abs(ddx * ax + ddy * ay) > body + ob + margin:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def body_touches(
    rows: np.ndarray, x: float, y: float, yaw: float, centre_x: float, hx: float, hy: float,
    margin: float,
) -> bool:  # fmt: skip
    """True if the body box of a robot at base_link pose (x, y, yaw) (m, rad), centred centre_x
    ahead of base_link with half sizes hx, hy (m), lies within margin (m) of any obstacle."""
    bx, by = x + centre_x * math.cos(yaw), y + centre_x * math.sin(yaw)
    reach = math.hypot(hx, hy) + margin
    for k in range(rows.shape[0]):
        row = rows[k]
        bound = row[3] if row[0] == CYLINDER else math.hypot(row[3], row[4])
        if math.hypot(row[1] - bx, row[2] - by) > bound + reach:
            continue
        if _box_touches(row, bx, by, yaw, hx, hy, margin):
            return True
    return False
