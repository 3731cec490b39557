"""The one import of PyBullet, without the ``pybullet build time: ...`` banner.

PyBullet's C extension prints that line to the process's standard error while it is
imported, so every process that simulates (each evaluation worker, each training env
worker) would write it between the progress bars. Importing it here, with the C-level file
descriptors 1 and 2 pointed at the null device for the length of the import, drops the
line; nothing else is printed then. Modules that call PyBullet import ``p`` from here::

    from d3dwa_bullet.sim.bullet import p

If the descriptors cannot be redirected (a process without a standard error), the import
goes ahead as usual and the banner shows.
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


def _flush_c_stdio() -> None:
    """Write out what C's stdio buffers hold (so it lands while the redirect is in force)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library to name (Windows)
        pass


@contextmanager
def silenced_fds() -> Iterator[None]:
    """Point file descriptors 1 and 2 at the null device for the block, then restore them.

    Python's own streams are flushed first, so text printed before the block is not lost.
    """
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    try:
        saved = (os.dup(1), os.dup(2))
    except OSError:  # a descriptor is closed: nothing to protect
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
        _flush_c_stdio()
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


if "pybullet" in sys.modules:  # already imported (and its banner already printed)
    import pybullet as p
else:
    with silenced_fds():
        import pybullet as p

__all__ = ["p", "silenced_fds"]
