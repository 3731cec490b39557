"""Running the ``d3dwa`` command in-process from a test, and the one-line refusal it must give."""

from __future__ import annotations

import pytest

from d3dwa_bullet.cli.app import main


def run(capsys: pytest.CaptureFixture, *argv: object) -> tuple[int, str, str]:
    """Run ``d3dwa argv``; (exit status, stdout, stderr)."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def refused(capsys: pytest.CaptureFixture, *argv: object) -> str:
    """Run argv, expect exit 2 and exactly one ``d3dwa: error:`` line; return that line."""
    code, _, err = run(capsys, *argv)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("d3dwa: error: "), (code, err)
    return lines[0]
