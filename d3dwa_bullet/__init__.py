"""d3dwa-bullet: a PyBullet sim-to-real testbed for D3DWA on a Kachaka robot."""

from pathlib import Path

__version__ = "0.1.0"

#: Repository root (worlds/, urdf/ live here; the package is installed editable).
REPO_ROOT = Path(__file__).resolve().parent.parent
URDF_DIR = REPO_ROOT / "urdf"
WORLDS_DIR = REPO_ROOT / "worlds"
