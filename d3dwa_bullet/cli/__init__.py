"""The ``d3dwa`` command line: one module per command, shared options in ``options``."""

from d3dwa_bullet.cli.app import main

__all__ = ["main"]
