"""Gazebo SDF ``.world`` files made of box and cylinder models, loaded as a :class:`World`.

What is read: every ``<model>`` under ``<world>`` (nested models too), each ``<link>``'s
``<collision>`` elements with ``<geometry><box><size>`` or ``<geometry><cylinder>
<radius><length>``. Poses (``x y z roll pitch yaw``) are composed model -> link ->
collision in the plane: only x, y and yaw are kept; roll and pitch are ignored (noted
in the warning), and every pose is taken relative to its parent element (SDF 1.7
``relative_to`` frames are not resolved). Every model is loaded as a static obstacle,
whatever its ``<static>``.

An obstacle stands on the floor up to the top of the SDF shape (z + half its height), so
a shape hovering a little above the floor becomes a solid column down to it. Shapes
entirely below z = 0, or whose bottom is above OVERHEAD_HEIGHT (a table top, a shelf:
nothing Kachaka's body or lidar can touch), are skipped. Everything else -- ``<include>`` (ground_plane, sun, model URIs), plane, mesh,
sphere, capsule, ellipsoid, heightmap and polyline geometry -- is skipped and listed in
one ``warnings.warn``.

SDF has no start pose or goal. Unless given, the start is (0, 0, 0) and the goal is
(1, 0): placeholders, not validated (an obstacle may well stand on them), for callers
(the CLI's ``--start/--goal``) to replace with ``world.with_task(start, goal)``, which
validates them. Pass ``start``/``goal`` here to get a validated world directly.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.loading import load_xml
from d3dwa_bullet.world.model import Box, Cylinder, Obstacle, World, validate_task

DEFAULT_START = (0.0, 0.0, 0.0)
"""Start pose (x, y, yaw) given to worlds whose file has none."""
DEFAULT_GOAL = (1.0, 0.0)
"""Goal (x, y) given to worlds whose file has none; replace it with World.with_task."""
OVERHEAD_HEIGHT = 0.3
"""Shapes whose bottom is higher than this (m) pass over the robot and are skipped."""
TILT_TOLERANCE = 1e-6
"""Roll or pitch beyond this (rad) is reported as ignored."""

Pose2 = tuple[float, float, float]


def _compose(a: Pose2, b: Pose2) -> Pose2:
    """Planar pose b expressed in a's frame, returned in a's parent frame."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


class _Reader:
    """One pass over an SDF tree, collecting obstacles and skipped items."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.obstacles: list[Obstacle] = []
        self.skipped: list[str] = []

    def _numbers(self, elem: ET.Element | None, n: int, where: str, key: str) -> list[float]:
        text = (elem.text or "") if elem is not None else ""
        try:
            vals = [float(v) for v in text.split()]
        except ValueError as err:
            raise WorldFormatError(
                f"{self.path}: {where}: field '{key}' must be {n} numbers, got {text.strip()!r}"
            ) from err
        if len(vals) != n or not all(math.isfinite(v) for v in vals):
            raise WorldFormatError(
                f"{self.path}: {where}: field '{key}' must be {n} finite numbers, got {text.strip()!r}"
            )
        return vals

    def _pose(self, elem: ET.Element, where: str) -> tuple[Pose2, float]:
        """Planar pose and z of an element's own <pose> (identity if absent)."""
        pose = elem.find("pose")
        if pose is None or not (pose.text or "").strip():
            return (0.0, 0.0, 0.0), 0.0
        x, y, z, roll, pitch, yaw = self._numbers(pose, 6, where, "pose")
        if abs(roll) > TILT_TOLERANCE or abs(pitch) > TILT_TOLERANCE:
            self.skipped.append(f"{where}: roll/pitch ({roll:g}, {pitch:g}) ignored")
        return (x, y, yaw), z

    def _size(self, elem: ET.Element | None, where: str, key: str, n: int) -> list[float]:
        if elem is None:
            raise WorldFormatError(f"{self.path}: {where}: missing field '{key}'")
        vals = self._numbers(elem, n, where, key)
        if not all(v > 0 for v in vals):
            raise WorldFormatError(
                f"{self.path}: {where}: field '{key}' must be > 0, got {(elem.text or '').strip()!r}"
            )
        return vals

    def model(self, model: ET.Element, parent: Pose2, parent_z: float, prefix: str) -> None:
        name = prefix + model.get("name", "<unnamed>")
        where = f"model '{name}'"
        own, z = self._pose(model, where)
        pose, z = _compose(parent, own), parent_z + z
        for link in model.findall("link"):
            lwhere = f"{where} link '{link.get('name', '<unnamed>')}'"
            lpose, lz = self._pose(link, lwhere)
            for col in link.findall("collision"):
                cwhere = f"{lwhere} collision '{col.get('name', '<unnamed>')}'"
                cpose, cz = self._pose(col, cwhere)
                self.collision(col, _compose(_compose(pose, lpose), cpose), z + lz + cz, cwhere)
        for inc in model.findall("include"):
            self.include(inc, f"{where}: ")
        for child in model.findall("model"):
            self.model(child, pose, z, f"{name}::")

    def collision(self, col: ET.Element, pose: Pose2, z: float, where: str) -> None:
        geom = col.find("geometry")
        shapes = list(geom) if geom is not None else []
        if not shapes:
            raise WorldFormatError(f"{self.path}: {where}: missing field 'geometry'")
        shape = shapes[0]
        if shape.tag == "box":
            sx, sy, sz = self._size(shape.find("size"), f"{where} box", "size", 3)
            if not self._stands(z, sz, f"{where}: box"):
                return
            self.obstacles.append(
                Box(center=(pose[0], pose[1]), size=(sx, sy), yaw=pose[2], height=z + 0.5 * sz)
            )
        elif shape.tag == "cylinder":
            (radius,) = self._size(shape.find("radius"), f"{where} cylinder", "radius", 1)
            (length,) = self._size(shape.find("length"), f"{where} cylinder", "length", 1)
            if not self._stands(z, length, f"{where}: cylinder"):
                return
            self.obstacles.append(
                Cylinder(center=(pose[0], pose[1]), radius=radius, height=z + 0.5 * length)
            )
        else:
            self.skipped.append(f"{where}: {shape.tag} geometry")

    def _stands(self, z: float, height: float, what: str) -> bool:
        """Is a shape centred at height z, this tall, an obstacle on the floor?"""
        if z + 0.5 * height <= 0:
            self.skipped.append(f"{what} below the floor")
            return False
        if z - 0.5 * height > OVERHEAD_HEIGHT:
            self.skipped.append(f"{what} above the robot")
            return False
        return True

    def include(self, inc: ET.Element, prefix: str = "") -> None:
        uri = (inc.findtext("uri") or "").strip() or "<no uri>"
        name = (inc.findtext("name") or "").strip()
        self.skipped.append(f"{prefix}include {uri}" + (f" ('{name}')" if name else ""))


def load_sdf_world(
    path: str | Path,
    start: tuple[float, float, float] | None = None,
    goal: tuple[float, float] | None = None,
) -> World:
    """Load a Gazebo SDF world of box and cylinder models.

    Name = file stem, group "custom". Without ``start``/``goal`` the task is the
    placeholder (0, 0, 0) -> (1, 0), unvalidated (see the module docstring). Raises
    WorldFormatError naming file, model and field for malformed XML, elements nested deeper
    than MAX_XML_DEPTH, a missing or non-positive box size, or a cylinder without a
    positive radius/length.
    """
    path = Path(path)
    root = load_xml(path, WorldFormatError, "world file")  # bounded: size, depth, regular file
    worlds = [root] if root.tag == "world" else root.findall("world")
    if not worlds:
        raise WorldFormatError(
            f"{path}: missing field 'world' (no <world> element under <{root.tag}>)"
        )
    reader = _Reader(path)
    for world in worlds:
        for model in world.findall("model"):
            reader.model(model, (0.0, 0.0, 0.0), 0.0, "")
        for inc in world.findall("include"):
            reader.include(inc)
    if reader.skipped:
        warnings.warn(
            f"{path}: skipped {len(reader.skipped)} item(s) that are not box/cylinder "
            f"obstacles: {'; '.join(reader.skipped)}",
            stacklevel=2,
        )
    placeholder = start is None and goal is None
    out = World(
        name=path.stem,
        description=f"Gazebo SDF world {path.name}",
        start=tuple(float(v) for v in (start or DEFAULT_START)),  # type: ignore[arg-type]
        goal=tuple(float(v) for v in (goal or DEFAULT_GOAL)),  # type: ignore[arg-type]
        obstacles=tuple(reader.obstacles),
        group="custom",
        source=str(path),
    )
    if not placeholder:
        validate_task(out)
    return out
