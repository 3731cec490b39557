"""One writer per output directory: a lock that a results directory (``eval``, ``sweep``) or
a training run directory (``train --out``, each ``seed-<k>/``) is held under while a command
writes it.

Two commands started at once into one ``--out`` would otherwise both run: two trainings
interleave one run directory, two identical evaluations append every row twice. With
:func:`locked_dir` the second is refused with :class:`~d3dwa_bullet.errors.BusyError`
naming the holder's pid, before it writes anything.

The lock is ``fcntl.flock`` on ``<dir>/.d3dwa.lock`` (the holder's pid and host written in
it). The kernel drops a flock when its holder exits, however it ends, so a killed run never
leaves a stale lock: the file a killed run leaves behind is locked again by the next
command (a resume) as if it were new. A command that ends normally removes the file, so
the directory holds exactly what it held before. A process may take the lock of a directory
it already holds (a command locks its ``--out``, then the library call inside locks it
again): the inner call is a no-op.
"""

from __future__ import annotations

import errno
import fcntl
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from d3dwa_bullet.errors import BusyError, ConfigError

LOCK_FILE = ".d3dwa.lock"
"""The lock file inside a locked directory (a dot file: listings and globs skip it)."""

_held: dict[Path, int] = {}
"""Directories this process holds (resolved path -> nesting depth)."""


def _holder(fd: int) -> str:
    """The holder named from a lock file's content: pid N (and "on HOST" if not this host)."""
    try:
        words = os.pread(fd, 256, 0).decode("utf-8", "replace").split()
    except OSError:
        words = []
    if not words:  # the holder has locked the file but not written its pid yet
        return "pid unknown"
    pid, host = words[0], " ".join(words[1:2])
    return f"pid {pid}" + (f" on {host}" if host and host != socket.gethostname() else "")


def _make(directory: Path, what: str) -> bool:
    """Create directory (and parents) unless it exists; True if this call created it."""
    try:
        directory.mkdir(parents=True)
        return True
    except FileExistsError:
        if not directory.is_dir():
            raise ConfigError(f"{what} {directory}: exists and is not a directory") from None
        return False
    except OSError as err:
        raise ConfigError(f"{what} {directory}: cannot create it: {err.strerror}") from err


def _acquire(directory: Path, what: str) -> int:
    path = directory / LOCK_FILE
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o666)  # not via a link
        except FileNotFoundError:  # the directory was removed (empty) by its creator: again
            _make(directory, what)
            continue
        except OSError as err:
            why = "it is a symbolic link" if err.errno == errno.ELOOP else err.strerror
            raise ConfigError(
                f"{what} {directory}: cannot create its lock file {path.name}: {why}"
            ) from err
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise BusyError(
                f"{what} {directory}: being written by another d3dwa command ({holder}); wait "
                f"for it to end, or choose another {what}"
            ) from None
        except BaseException:
            os.close(fd)
            raise
        # the holder before us may have removed the file after we opened it: go on only
        # with the file the path names now
        try:
            current = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            current = False
        if current:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()} {socket.gethostname()}\n".encode(), 0)
            return fd
        os.close(fd)


@contextmanager
def locked_dir(directory: str | os.PathLike[str], what: str = "--out") -> Iterator[Path]:
    """Hold ``directory`` (created if missing, removed again if still empty at the end)
    for this process while the block runs.

    BusyError naming the holder's pid if another process holds it; ConfigError if the
    directory or its lock file cannot be created. what: the option that named the directory,
    for messages."""
    directory = Path(directory)
    created = _make(directory, what)
    key = directory.resolve()
    if key in _held:
        _held[key] += 1
        try:
            yield directory
        finally:
            _held[key] -= 1
        return
    fd = _acquire(directory, what)
    _held[key] = 1
    try:
        yield directory
    finally:
        del _held[key]
        try:  # removed while still held: a process that opened it meanwhile will retry
            (directory / LOCK_FILE).unlink(missing_ok=True)
        finally:
            os.close(fd)
        if created:  # a command refused before its first write leaves no empty directory
            try:
                directory.rmdir()
            except OSError:
                pass
