"""``d3dwa serve`` in its own process, for tests that drive a robot over real sockets."""

from __future__ import annotations

import re
import subprocess
import sys

D3DWA = [sys.executable, "-m", "d3dwa_bullet.cli"]


def start_serve(*extra: str, world: str = "R1") -> tuple[subprocess.Popen, str]:
    """``d3dwa serve --world world --port 0 ...`` and the address it prints."""
    proc = subprocess.Popen(
        [*D3DWA, "serve", "--world", world, "--port", "0", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    line = proc.stdout.readline()
    found = re.search(r"on (127\.0\.0\.1:\d+)", line)
    if not found:
        proc.kill()
        _, err = proc.communicate()
        raise AssertionError(f"d3dwa serve did not start: {line!r} {err}")
    return proc, found[1]
