"""Where the shipped data lives: worlds, the robot's URDF, policies, training configs, profiles.

Every folder is package data found through :mod:`importlib.resources`, so the same code reads
it from a wheel, a git-URL install or an editable checkout, from any working directory. The
folders sit at the top of the source tree (the design card's layout) and ``pyproject.toml``
maps them into ``d3dwa_bullet.data.*`` (profiles are ``randomization/profiles``).
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

from d3dwa_bullet.errors import InstallError

_PACKAGES = {
    "worlds": "d3dwa_bullet.data.worlds",
    "urdf": "d3dwa_bullet.data.urdf",
    "policies": "d3dwa_bullet.data.policies",
    "configs": "d3dwa_bullet.data.configs",
}
_FOLDERS = {"barn": "d3dwa_bullet.data"}
"""Data folders that are plain folders inside a package: name -> package."""
_REINSTALL = "reinstall with `pip install --force-reinstall d3dwa-bullet` (or `pip install .` from a checkout)"


def data_dir(name: str) -> Path:
    """The folder of shipped data ``name`` (worlds, urdf, policies, configs, profiles, barn).

    Raises InstallError, naming the folder and how to reinstall, when the install lacks it.
    """
    # randomization/profiles/ sits beside the module randomization/profiles.py, and barn/ is
    # a plain folder of d3dwa_bullet.data, so each is a folder of a package, not a package.
    package = _PACKAGES.get(name, _FOLDERS.get(name, "randomization"))
    try:
        root = importlib.resources.files(package)
        if name in ("profiles", "barn"):
            root = root / name
    except ModuleNotFoundError as err:
        raise InstallError(f"the install has no {name}/ data ({package}); {_REINSTALL}") from err
    path = Path(str(root))
    if not path.is_dir():
        raise InstallError(f"the install has no {name}/ data (looked in {path}); {_REINSTALL}")
    return path


def barn_dir() -> Path:
    """BARN's grids, reference paths, manifest and licence (``d3dwa_bullet/data/barn/``)."""
    return data_dir("barn")


def worlds_dir() -> Path:
    return data_dir("worlds")


def generators_dir() -> Path:
    return data_dir("worlds") / "generators"


def urdf_path(name: str = "kachaka.urdf") -> Path:
    path = data_dir("urdf") / name
    if not path.is_file():
        raise InstallError(f"the install has no urdf/{name} (looked in {path}); {_REINSTALL}")
    return path


def policies_dir() -> Path:
    return data_dir("policies")


def configs_dir() -> Path:
    return data_dir("configs")


def profiles_dir() -> Path:
    return data_dir("profiles")
