"""How a method from outside the package is named (docs/design/external-methods.md#external-methods): a class as
``package.module:Name``, an ONNX file, or an entry point of :data:`ENTRY_POINT_GROUP`.

The naming rules sit here, below both :mod:`d3dwa_bullet.method_specs` (which judges a name) and
:mod:`d3dwa_bullet.external` (which loads what it names), so neither imports the other for them.
Pure: the standard library only; installed packages' metadata is read only when asked.
"""

from __future__ import annotations

import re
from importlib.metadata import EntryPoint, entry_points

__all__ = [
    "ENTRY_POINT_GROUP",
    "MODEL_SUFFIXES",
    "entry_point_clashes",
    "entry_points_named",
    "installed_entry_points",
    "is_import_path",
    "is_model_file",
]

#: The entry point group an installed package registers its methods under (name = method).
ENTRY_POINT_GROUP = "d3dwa_bullet.methods"
#: A method named by a file: an ONNX policy with the contract ``d3dwa export`` writes.
MODEL_SUFFIXES = (".onnx",)
_IMPORT_PATH = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")


def is_model_file(name: str) -> bool:
    """Whether name is a path to a model file a method runs (``policy.onnx``)."""
    return name.lower().endswith(MODEL_SUFFIXES)


def is_import_path(name: str) -> bool:
    """Whether name is spelled ``package.module:Name``."""
    return _IMPORT_PATH.fullmatch(name) is not None


def installed_entry_points() -> list[EntryPoint]:
    """Every installed entry point of :data:`ENTRY_POINT_GROUP`, in the order found (none loaded);
    two packages may register the same name."""
    return list(entry_points(group=ENTRY_POINT_GROUP))


def entry_points_named() -> dict[str, EntryPoint]:
    """The installed entry points by name (none loaded); a name two packages register maps to
    the first found, and :func:`entry_point_clashes` names it, so it is refused, never taken
    silently."""
    out: dict[str, EntryPoint] = {}
    for ep in installed_entry_points():
        out.setdefault(ep.name, ep)
    return out


def entry_point_clashes() -> dict[str, list[str]]:
    """{name: what each registration points at, ``module:Name (distribution)``} for every name
    registered more than once in the group."""
    found: dict[str, list[str]] = {}
    for ep in installed_entry_points():
        dist = getattr(ep, "dist", None)
        found.setdefault(ep.name, []).append(
            f"{ep.value} ({dist.name})" if dist is not None else ep.value
        )
    return {name: values for name, values in found.items() if len(values) > 1}
