"""The house's arrows between modules that once leaned on each other (HOUSE.md): every import
counts here, one under ``if TYPE_CHECKING:`` included, so a circle hidden in annotations shows."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import d3dwa_bullet

ROOT = Path(d3dwa_bullet.__file__).parent


def imported(module: str) -> set[str]:
    """Every module a first-party module names in an import, at any depth of its code."""
    path = ROOT.joinpath(*module.split(".")[1:]).with_suffix(".py")
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize(
    ("low", "high"),
    [
        ("d3dwa_bullet.evaluation.reuse", "d3dwa_bullet.evaluation.jobs"),
        ("d3dwa_bullet.learning.training.config_checks", "d3dwa_bullet.learning.training.config"),
        ("d3dwa_bullet.method_specs", "d3dwa_bullet.external.protocol"),
        ("d3dwa_bullet.method_names", "d3dwa_bullet.method_specs"),
        ("d3dwa_bullet.method_names", "d3dwa_bullet.external.protocol"),
    ],
)
def test_the_lower_module_never_names_the_higher(low, high):
    assert not any(m == high or m.startswith(high + ".") for m in imported(low))


def test_the_pairs_still_meet_where_the_names_live():
    """The names each needed now have one home both import."""
    assert "d3dwa_bullet.evaluation.job" in imported("d3dwa_bullet.evaluation.reuse")
    assert "d3dwa_bullet.evaluation.job" in imported("d3dwa_bullet.evaluation.jobs")
    assert "d3dwa_bullet.method_names" in imported("d3dwa_bullet.method_specs")
    assert "d3dwa_bullet.method_names" in imported("d3dwa_bullet.external.protocol")
