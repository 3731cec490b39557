"""Running code, or the ``d3dwa`` command, in a subprocess whose files may not grow past a
size (RLIMIT_FSIZE): a write past it fails with EFBIG ("File too large") as one on a full
disk fails with ENOSPC, without filling a disk or needing root."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
"""This worktree: the subprocess imports its d3dwa_bullet, as pytest does."""


def run_python_with_file_limit(code: str, limit: int) -> subprocess.CompletedProcess[str]:
    """Run python code with files limited to ``limit`` bytes (SIGXFSZ ignored, so the write
    fails instead of the process being killed)."""
    prelude = (
        "import resource, signal\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-c", prelude + code],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        cwd=REPO,
    )


def run_d3dwa_with_file_limit(
    argv: Sequence[object], limit: int
) -> subprocess.CompletedProcess[str]:
    """``d3dwa argv`` with files limited to ``limit`` bytes."""
    args = [str(a) for a in argv]
    return run_python_with_file_limit(
        f"import sys\nfrom d3dwa_bullet.cli.app import main\nsys.exit(main({args!r}))\n", limit
    )


def error_lines(stderr: str) -> list[str]:
    """stderr's lines other than progress bars (``episodes:  50%|#####  | 1/2 ...``)."""
    return [line for line in stderr.splitlines() if line.strip() and "%|" not in line]
