"""Atomic file writes (a reader sees the old file or the new one, never half of either),
and reading a text file with an error that names it.

Each helper writes to a temporary file beside the target (same directory, so the rename
never crosses a file system), fsyncs it, then ``os.replace``s it over the target. If the
write fails, the temporary file is removed and the target is left as it was. The temporary
name starts with a dot and ends in ``.tmp``; it is created with mode 0666 minus the umask,
like an ordinary ``open(path, "w")``. The parent directory must exist. A file system that
refuses the write (a full disk, the file-size limit, a read-only directory, a file where a
directory should be) raises :class:`~d3dwa_bullet.errors.WriteError`, one line naming the
target and the reason, which the command line prints as its error.

:class:`AppendFile` is the other way a file grows: whole records at its end (rows of
results.csv, lines of a training log), each written whole or not at all, never through a
symbolic link.

:func:`read_text` reads a UTF-8 file the user named (a world, a profile, a map): a file of
binary garbage or one that cannot be read is the caller's error class with one line that
names the file, not a ``UnicodeDecodeError``. It reads only regular files (not ``/dev/zero``,
a FIFO or a directory) and refuses a file over its size limit before reading it
(:mod:`d3dwa_bullet.limits`); YAML and JSON go through :mod:`d3dwa_bullet.loading`.

:func:`file_stem` makes a name read from a file or typed by the user (a world's ``name:``)
safe to use in a file name: it stays in its directory and within the file system's length.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import secrets
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from d3dwa_bullet.errors import D3DWAError, WriteError
from d3dwa_bullet.limits import MAX_STEM_BYTES, MAX_TEXT_BYTES, Limit


class SavesFigure(Protocol):
    """Anything with matplotlib's ``Figure.savefig(file, **kw)`` (no matplotlib import here)."""

    def savefig(self, fname: Any, **kwargs: Any) -> Any: ...


TEMP_NAME_EXTRA = len(".") + len(f".{secrets.token_hex(4)}.tmp")
"""Bytes the temporary name of an atomic write adds to the target's name (a name that fits
the file system only without them cannot be written atomically)."""
_PATH_UNSAFE = re.compile(r"[/\\\x00-\x1f\x7f\ud800-\udfff]")
"""Characters that never go into a file name: path separators, control characters and
lone surrogates (not encodable)."""


def file_stem(name: str) -> str:
    """``name`` as (the start of) a file name in one directory: ``name`` itself when it has
    no path separator or control character, is not ``.`` or ``..`` and fits
    :data:`~d3dwa_bullet.limits.MAX_STEM_BYTES`; otherwise those characters become ``_``,
    the result is cut to fit, and ``-`` and 10 hex digits of the SHA-256 of ``name`` follow,
    so two names never share a stem. ``TS1`` -> ``TS1``; ``../../escape`` ->
    ``.._.._escape-<hash>``."""
    cleaned = _PATH_UNSAFE.sub("_", name)
    limit = int(MAX_STEM_BYTES.value)
    if cleaned == name and name not in ("", ".", "..") and len(name.encode()) <= limit:
        return name
    digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:10]
    head = cleaned.encode()[: limit - len(digest) - 1].decode("utf-8", "ignore")
    return f"{head}-{digest}"


def name_room(directory: str | os.PathLike[str]) -> int:
    """Bytes a file name in ``directory`` may have and still be written atomically there
    (the file system's NAME_MAX, 255 where it cannot be asked, less TEMP_NAME_EXTRA)."""
    try:
        name_max = os.pathconf(directory, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    return (name_max if name_max > 0 else 255) - TEMP_NAME_EXTRA


def _atomic_write(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> Path:
    target = Path(path)
    while True:  # O_EXCL: a name no other writer holds (a clash is all but impossible)
        tmp = target.with_name(f".{target.name}.{secrets.token_hex(4)}.tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
            break
        except FileExistsError:
            continue
        except OSError as err:  # read-only, a file where the directory should be, ...
            raise WriteError(target, err) from err
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException as err:
        tmp.unlink(missing_ok=True)
        if isinstance(err, OSError) and not isinstance(err, WriteError):
            raise WriteError(target, err) from err  # a full disk, past the file-size limit
        raise
    return target


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Replace path's content with data, atomically; returns path as a Path."""
    return _atomic_write(path, lambda fh: fh.write(data))


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Replace path's content with text (encoded, newlines as given), atomically."""
    return atomic_write_bytes(path, text.encode(encoding))


def atomic_savefig(fig: SavesFigure, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """``fig.savefig(path, **kwargs)``, atomically. The format comes from path's suffix
    unless ``format=`` is given. The figure is not closed."""
    suffix = Path(path).suffix.lstrip(".")
    if suffix and "format" not in kwargs:
        kwargs["format"] = suffix
    return _atomic_write(path, lambda fh: fig.savefig(fh, **kwargs))


_APPEND_FLAGS = (
    os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
)
"""O_NOFOLLOW: a link planted in an output directory is never written through; O_NONBLOCK:
opening a FIFO does not wait for a reader (it is then refused as no regular file)."""


class AppendFile:
    """A regular file that grows by whole records (rows of results.csv, lines of a log),
    created if missing. A record goes in whole or not at all: when a write fails (a full
    disk, the file-size limit) the file is cut back to where it ended, and WriteError names
    it. A symbolic link or anything but a regular file is refused when opening (WriteError),
    so a command never appends outside the directory it writes. A context manager."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        try:
            self._fd = os.open(self.path, _APPEND_FLAGS, 0o666)
        except OSError as err:
            raise WriteError(self.path, err) from err
        if not stat.S_ISREG(os.fstat(self._fd).st_mode):
            os.close(self._fd)
            raise WriteError(self.path, OSError(errno.EINVAL, "not a regular file"))
        os.set_blocking(self._fd, True)

    @property
    def size(self) -> int:
        """Bytes in the file now."""
        return os.fstat(self._fd).st_size

    def write(self, data: bytes) -> None:
        """Append data, all of it or (on failure, then WriteError) none of it."""
        start = os.lseek(self._fd, 0, os.SEEK_END)
        view = memoryview(data)
        try:
            while view:
                view = view[os.write(self._fd, view) :]
        except OSError as err:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, start)
            raise WriteError(self.path, err) from err

    def cut(self, size: int) -> None:
        """Cut the file back to its first size bytes (a resumed run's logs to its checkpoint)."""
        try:
            os.ftruncate(self._fd, size)
        except OSError as err:
            raise WriteError(self.path, err) from err

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> AppendFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_text(
    path: str | os.PathLike[str],
    error: type[D3DWAError],
    what: str = "file",
    limit: Limit = MAX_TEXT_BYTES,
) -> str:
    """The text of a UTF-8 file, or ``error`` naming the file when it cannot be read, is not
    a regular file, is larger than ``limit`` bytes or is not text (what: the kind of file
    the user meant, for the message: "world file", ...)."""
    p = Path(path)
    try:
        if not stat.S_ISREG(os.stat(p).st_mode):  # before open: a FIFO would block it
            raise error(f"{p}: not a regular file; a {what} must be one")
        with p.open("rb") as fh:
            limit.check(f"{p}", os.fstat(fh.fileno()).st_size, "bytes", error)
            data = fh.read(int(limit.value) + 1)  # the file may have grown since fstat
        limit.check(f"{p}", len(data), "bytes", error)
        # newlines as a text-mode read gives them (\r\n and \r read as \n)
        return data.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
    except UnicodeDecodeError as err:
        raise error(
            f"{p}: not a text {what} (byte {err.object[err.start]:#04x} at offset {err.start} "
            "is not UTF-8)"
        ) from err
    except OSError as err:
        raise error(f"{p}: cannot read: {err.strerror or err}") from err
