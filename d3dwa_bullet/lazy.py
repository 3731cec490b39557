"""Lazy re-exports for a subpackage ``__init__`` whose modules import heavy libraries.

A subpackage re-exports its public names (HOUSE.md), but importing a pure module such as
``d3dwa_bullet.sim.scan`` runs ``d3dwa_bullet/sim/__init__.py`` first: if that imported the
simulator eagerly, every pure module would pull in pybullet. ``lazy_exports`` instead returns
the module-level ``__getattr__`` and ``__dir__`` (PEP 562) that import each name from its home
module on first access and cache it in the package namespace.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    namespace: dict[str, Any], homes: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """(__getattr__, __dir__) for a package whose globals are ``namespace``.

    homes: re-exported name -> the dotted module that defines it.
    """
    package = namespace["__name__"]

    def __getattr__(name: str) -> Any:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(homes))

    return __getattr__, __dir__
