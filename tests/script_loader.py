"""Load a file of scripts/ (not a package) as a module, for tests of its functions."""

from __future__ import annotations

import importlib.util
from types import ModuleType

from d3dwa_bullet import REPO_ROOT


def load_script(name: str) -> ModuleType:
    """scripts/<name>.py, executed as a fresh module named ``name``."""
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module
