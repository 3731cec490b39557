"""Generator styles by name: the R-style YAML styles and the BARN-style family, one entry point.

Training's ``generators:`` and its layout draws (learning/tasks.py) go through
:func:`generate_layout`: a style is a shipped or given generator YAML
(:func:`~d3dwa_bullet.world.generator.generate_world`) or ``BARN-style``
(:func:`~d3dwa_bullet.world.barn_style.barn_style_world`).
"""

from __future__ import annotations

from d3dwa_bullet.world.barn_style import STYLE, barn_style_world
from d3dwa_bullet.world.generator import generate_world
from d3dwa_bullet.world.generator_spec import load_generator
from d3dwa_bullet.world.model import World


def is_barn_style(style: str) -> bool:
    """True if ``style`` names the BARN-style family (any case)."""
    return str(style).upper() == STYLE.upper()


def check_style(style: str) -> None:
    """UnknownNameError (or WorldFormatError for a bad file) unless ``style`` is a generator
    style :func:`generate_layout` takes."""
    if not is_barn_style(style):
        load_generator(style)


def generate_layout(style: str, seed: int) -> World:
    """The layout of ``style`` and ``seed``: BARN-style or a generator YAML's (module docstring)."""
    return barn_style_world(seed) if is_barn_style(style) else generate_world(style, seed)
