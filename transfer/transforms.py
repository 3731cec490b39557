"""Rigid transforms for bags: quaternion <-> yaw, and a small tf tree.

Transforms are (4, 4) float64 homogeneous matrices ``T_parent_child`` (the child frame's
pose in the parent frame). Frame names are compared without a leading ``/`` (ROS 1 style).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from d3dwa_bullet.geometry import wrap_angle
from d3dwa_bullet.sim.scan import Pose2D

_MAX_NUDGE_ULP = 3


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Heading of a rotation (REP-103 yaw), rad in (-pi, pi].

    A pure yaw quaternion (x = y = 0) is decoded as ``2 atan2(z, w)``, which
    ``quaternion_from_yaw`` inverts exactly; anything else as the heading of the rotated x
    axis (scale-invariant, so unnormalised quaternions are fine).
    """
    if x == 0.0 and y == 0.0:
        return wrap_angle(2.0 * math.atan2(z, w))
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by yaw about z, chosen so ``yaw_from_quaternion`` returns yaw.

    yaw is wrapped to (-pi, pi] first. The textbook (sin(yaw/2), cos(yaw/2)) decodes back
    to yaw within 1 ulp; nudging z by a few ulp (a rotation change below 1e-15 rad) makes
    the round trip bit-exact, so a recorded pose replays to the same float64 values. Below
    |yaw| = 2 x the smallest normal float (4.5e-308 rad) sin(yaw/2) is subnormal and the
    round trip is exact only to one subnormal step (5e-324 rad).
    """
    yaw = wrap_angle(float(yaw))
    z, w = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
    for k in range(_MAX_NUDGE_ULP + 1):
        for direction in (math.inf, -math.inf) if k else (0.0,):
            zz = z
            for _ in range(k):
                zz = math.nextafter(zz, direction)
            if yaw_from_quaternion(0.0, 0.0, zz, w) == yaw:
                return (0.0, 0.0, zz, w)
    return (0.0, 0.0, z, w)


def matrix_from_transform(
    translation: tuple | np.ndarray, quaternion: tuple | np.ndarray
) -> np.ndarray:
    """(4, 4) from translation (x, y, z), m, and quaternion (x, y, z, w) (normalised here)."""
    qx, qy, qz, qw = (float(v) for v in quaternion)
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not n > 0 or not math.isfinite(n):
        raise ValueError(f"quaternion {quaternion!r} is not a rotation")
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    t = np.eye(4)
    t[:3, :3] = [
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ]
    t[:3, 3] = [float(v) for v in translation]
    return t


def invert(t: np.ndarray) -> np.ndarray:
    """Inverse of a rigid (4, 4) transform."""
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def pose2d_from_matrix(t: np.ndarray) -> tuple[Pose2D, bool]:
    """Planar pose of a (4, 4) transform, and whether the child frame is upside down.

    Upside down (child z axis pointing down): a beam at angle a in the child frame points
    at ``yaw - a`` in the parent frame instead of ``yaw + a``.
    """
    yaw = math.atan2(t[1, 0], t[0, 0])
    return Pose2D(float(t[0, 3]), float(t[1, 3]), yaw), bool(t[2, 2] < 0.0)


def _frame(name: str) -> str:
    return name.lstrip("/")


@dataclass
class TransformTree:
    """Static and time-stamped transforms from /tf_static and /tf, looked up along any path."""

    static: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    dynamic: dict[tuple[str, str], list[tuple[int, np.ndarray]]] = field(default_factory=dict)

    def add(self, parent: str, child: str, t: np.ndarray, stamp_ns: int | None = None) -> None:
        """Add ``T_parent_child``; ``stamp_ns=None`` marks it static."""
        key = (_frame(parent), _frame(child))
        if stamp_ns is None:
            self.static[key] = t
        else:
            self.dynamic.setdefault(key, []).append((stamp_ns, t))

    def frames(self) -> set[str]:
        return {f for key in (*self.static, *self.dynamic) for f in key}

    def _edge(self, key: tuple[str, str], stamp_ns: int | None) -> np.ndarray:
        if key in self.static:
            return self.static[key]
        samples = self.dynamic[key]
        if stamp_ns is None:
            return samples[0][1]
        return min(samples, key=lambda s: abs(s[0] - stamp_ns))[1]

    def path(self, target: str, source: str) -> list[str] | None:
        """Frames from target to source (inclusive), or None if they are not connected."""
        target, source = _frame(target), _frame(source)
        neighbours: dict[str, set[str]] = {}
        for a, b in (*self.static, *self.dynamic):
            neighbours.setdefault(a, set()).add(b)
            neighbours.setdefault(b, set()).add(a)
        if target not in neighbours or source not in neighbours:
            return [target] if target == source else None
        previous: dict[str, str | None] = {target: None}
        queue = deque([target])
        while queue:
            f = queue.popleft()
            if f == source:
                break
            for g in sorted(neighbours[f]):
                if g not in previous:
                    previous[g] = f
                    queue.append(g)
        if source not in previous:
            return None
        chain = [source]
        while (p := previous[chain[-1]]) is not None:
            chain.append(p)
        return chain[::-1]

    def lookup(self, target: str, source: str, stamp_ns: int | None = None) -> np.ndarray | None:
        """``T_target_source`` (the source frame's pose in target), or None if unconnected.

        Static edges are used as they are; a dynamic edge contributes its sample nearest to
        stamp_ns (its first sample when stamp_ns is None).
        """
        chain = self.path(target, source)
        if chain is None:
            return None
        t = np.eye(4)
        for a, b in zip(chain[:-1], chain[1:], strict=True):
            if (a, b) in self.static or (a, b) in self.dynamic:
                t = t @ self._edge((a, b), stamp_ns)
            else:
                t = t @ invert(self._edge((b, a), stamp_ns))
        return t
