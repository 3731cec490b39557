"""Reading one field of a world or generator file, with errors that name file, field and value.

``where`` is the file (and the entry inside it, e.g. ``TS1.yaml: obstacles[2]``) that the
error message starts with.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from d3dwa_bullet.errors import WorldFormatError


def required(data: Mapping[str, Any], key: str, where: str) -> Any:
    """``data[key]``, or WorldFormatError naming the missing field."""
    if key not in data:
        raise WorldFormatError(f"{where}: missing field '{key}'")
    return data[key]


def vector(value: Any, n: int, where: str, key: str) -> tuple[float, ...]:
    """``n`` finite numbers as a tuple of floats, or WorldFormatError."""
    try:
        vec = tuple(float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise WorldFormatError(
            f"{where}: field '{key}' must be {n} numbers, got {value!r}"
        ) from err
    if len(vec) != n or not all(math.isfinite(v) for v in vec):
        raise WorldFormatError(f"{where}: field '{key}' must be {n} finite numbers, got {value!r}")
    return vec


def positive(value: Any, where: str, key: str) -> float:
    """A finite number > 0 as a float, or WorldFormatError."""
    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise WorldFormatError(f"{where}: field '{key}' must be a number, got {value!r}") from err
    if not (math.isfinite(v) and v > 0):
        raise WorldFormatError(f"{where}: field '{key}' must be > 0, got {value!r}")
    return v
