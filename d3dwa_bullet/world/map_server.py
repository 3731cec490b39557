"""ROS map_server occupancy maps (``.yaml`` + image) loaded as a :class:`World` of boxes.

The YAML keys are those of map_server: ``image`` (path, relative to the YAML file),
``resolution`` (m/pixel), ``origin`` ([x, y, yaw] of the lower-left corner of the
lower-left pixel), ``negate`` (0/1), ``occupied_thresh``, ``free_thresh`` and optionally
``mode`` (``trinary`` default, ``scale`` or ``raw``). All but ``mode`` are required.

A pixel's occupancy is p = (255 - value) / 255, or value / 255 with ``negate``; pixels with
p > occupied_thresh become obstacles. In ``raw`` mode the value itself is the occupancy
in percent (0..100) and values above 100 (unknown) are free. Unknown and free pixels alike
are empty space. Image row 0 is the top of the map (largest y).

Occupied pixels of a row are merged into runs, and identical runs of consecutive rows into
one box, to keep the body count low; each box is rotated by the origin's yaw. Start and
goal default as in :mod:`~d3dwa_bullet.world.sdf` ((0, 0, 0) -> (1, 0), placeholders to
replace with ``World.with_task``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.limits import MAX_MAP_BOXES, MAX_MAP_PIXELS
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.world.model import DEFAULT_HEIGHT, Box, World, validate_task
from d3dwa_bullet.world.sdf import DEFAULT_GOAL, DEFAULT_START

MODES = ("trinary", "scale", "raw")
RAW_OCCUPANCY_MAX = 100
"""In raw mode a value is an occupancy in percent; larger values mean unknown."""


def _number(data: Mapping[str, Any], key: str, where: str) -> float:
    if key not in data:
        raise WorldFormatError(f"{where}: missing field '{key}'")
    try:
        value = float(data[key])
    except (TypeError, ValueError) as err:
        raise WorldFormatError(
            f"{where}: field '{key}' must be a number, got {data[key]!r}"
        ) from err
    if not math.isfinite(value):
        raise WorldFormatError(f"{where}: field '{key}' must be finite, got {data[key]!r}")
    return value


def occupied_cells(
    pixels: np.ndarray, negate: bool, occupied_thresh: float, mode: str = "trinary"
) -> np.ndarray:
    """Occupied mask of a map image: pixels (H, W) uint8 -> (H, W) bool, row 0 = top."""
    values = pixels.astype(np.float64)
    if mode == "raw":
        return (values <= RAW_OCCUPANCY_MAX) & (values / RAW_OCCUPANCY_MAX > occupied_thresh)
    p = values / 255.0 if negate else (255.0 - values) / 255.0
    return p > occupied_thresh


def mask_to_boxes(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover an occupied mask (H, W) with rectangles (row0, row1, col0, col1), inclusive.

    Runs of occupied pixels along each row, then identical runs in consecutive rows merged.
    """
    h, w = occupied.shape
    padded = np.zeros((h, w + 2), dtype=np.int8)
    padded[:, 1:-1] = occupied
    edges = np.diff(padded, axis=1)
    boxes: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row
    for r in range(h):
        starts = np.flatnonzero(edges[r] == 1)
        ends = np.flatnonzero(edges[r] == -1) - 1
        runs = set(zip(starts.tolist(), ends.tolist(), strict=True))
        for run in [k for k in open_runs if k not in runs]:
            boxes.append((open_runs.pop(run), r - 1, *run))
        for run in runs:
            open_runs.setdefault(run, r)
    boxes += [(r0, h - 1, *run) for run, r0 in open_runs.items()]
    return sorted(boxes)


def image_size(path: Path) -> tuple[int, int] | None:
    """(width, height) of a PNG or a PGM/PPM/PBM image from its header, without decoding
    it; None for another format or a header that cannot be read (left to the decoder)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(4096)
    except OSError:
        return None
    if head.startswith(b"\x89PNG\r\n\x1a\n") and head[12:16] == b"IHDR":
        return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    if len(head) > 2 and head[:1] == b"P" and head[1:2] in b"123456":
        # P<n>, then width and height as decimal text, with '#' comments to end of line
        text = b"\n".join(line.split(b"#")[0] for line in head[2:].split(b"\n"))
        fields = text.split()
        if len(fields) >= 2 and fields[0].isdigit() and fields[1].isdigit():
            return int(fields[0]), int(fields[1])
    return None


def load_map_world(
    yaml_path: str | Path,
    start: tuple[float, float, float] | None = None,
    goal: tuple[float, float] | None = None,
    height: float = DEFAULT_HEIGHT,
) -> World:
    """Load a map_server map as a World of upright boxes ``height`` m tall.

    Name = YAML file stem, group "custom". Raises WorldFormatError naming the file and
    field for a missing key, a bad value or an unreadable image.
    """
    yaml_path = Path(yaml_path)
    where = str(yaml_path)
    data = load_yaml(yaml_path, WorldFormatError, "map YAML")
    if not isinstance(data, Mapping):
        raise WorldFormatError(f"{where}: top level must be a mapping, got {type(data).__name__}")
    if "image" not in data:
        raise WorldFormatError(f"{where}: missing field 'image'")
    resolution = _number(data, "resolution", where)
    if resolution <= 0:
        raise WorldFormatError(
            f"{where}: field 'resolution' must be > 0, got {data['resolution']!r}"
        )
    if "origin" not in data:
        raise WorldFormatError(f"{where}: missing field 'origin'")
    try:
        ox, oy, oyaw = (float(v) for v in data["origin"])
    except (TypeError, ValueError) as err:
        raise WorldFormatError(
            f"{where}: field 'origin' must be [x, y, yaw], got {data['origin']!r}"
        ) from err
    if not all(math.isfinite(v) for v in (ox, oy, oyaw)):
        raise WorldFormatError(f"{where}: field 'origin' must be finite, got {data['origin']!r}")
    negate = _number(data, "negate", where)
    if negate not in (0.0, 1.0):
        raise WorldFormatError(f"{where}: field 'negate' must be 0 or 1, got {data['negate']!r}")
    occupied_thresh = _number(data, "occupied_thresh", where)
    free_thresh = _number(data, "free_thresh", where)
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise WorldFormatError(
            f"{where}: fields 'free_thresh' = {free_thresh} and 'occupied_thresh' = "
            f"{occupied_thresh} must satisfy 0 <= free_thresh <= occupied_thresh <= 1"
        )
    mode = str(data.get("mode", "trinary"))
    if mode not in MODES:
        raise WorldFormatError(f"{where}: field 'mode' = {mode!r} is not one of {MODES}")
    image_path = Path(str(data["image"]))
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    size = image_size(image_path) if image_path.is_file() else None
    if size is not None:
        MAX_MAP_PIXELS.check(f"{where}: image {image_path} ({size[0]} x {size[1]} px)",
                             size[0] * size[1], "pixels", WorldFormatError)  # fmt: skip
    pixels = cv2.imread(str(image_path), cv2.IMREAD_GRAYSCALE) if image_path.is_file() else None
    if pixels is None:
        raise WorldFormatError(
            f"{where}: field 'image' = {str(data['image'])!r}: cannot read {image_path}"
        )

    occupied = occupied_cells(pixels, bool(negate), occupied_thresh, mode)
    rows = pixels.shape[0]
    c, s = math.cos(oyaw), math.sin(oyaw)
    obstacles = []
    boxes = mask_to_boxes(occupied)
    MAX_MAP_BOXES.check(f"{where}: occupied regions", len(boxes), "boxes", WorldFormatError)
    for r0, r1, c0, c1 in boxes:
        # map-frame centre: x grows with the column, y grows upwards from the bottom row
        lx = 0.5 * (c0 + c1 + 1) * resolution
        ly = (rows - 0.5 * (r0 + r1 + 1)) * resolution
        obstacles.append(
            Box(
                center=(ox + c * lx - s * ly, oy + s * lx + c * ly),
                size=((c1 - c0 + 1) * resolution, (r1 - r0 + 1) * resolution),
                yaw=oyaw,
                height=height,
            )
        )
    out = World(
        name=yaml_path.stem,
        description=f"map_server map {yaml_path.name} ({pixels.shape[1]} x {rows} px at {resolution:g} m)",
        start=tuple(float(v) for v in (start or DEFAULT_START)),  # type: ignore[arg-type]
        goal=tuple(float(v) for v in (goal or DEFAULT_GOAL)),  # type: ignore[arg-type]
        obstacles=tuple(obstacles),
        group="custom",
        source=where,
    )
    if start is not None or goal is not None:
        validate_task(out)
    return out
