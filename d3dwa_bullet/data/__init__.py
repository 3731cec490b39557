"""Shipped data, one subpackage per folder of the source tree (see ``d3dwa_bullet.resources``).

The folders themselves live at the top of the repository (``worlds/``, ``urdf/``,
``policies/``, ``configs/``) and are mapped into this package by ``pyproject.toml``, so a
wheel carries them and an editable install reads them in place.
"""
