"""Atomic file writes (a reader sees the old file or the new one, never half of either),
and reading a text file with an error that names it.

Each helper writes to a temporary file beside the target (same directory, so the rename
never crosses a file system), fsyncs it, then ``os.replace``s it over the target. If the
write fails, the temporary file is removed and the target is left as it was. The temporary
name starts with a dot and ends in ``.tmp``; it is created with mode 0666 minus the umask,
like an ordinary ``open(path, "w")``. The parent directory must exist.

:func:`read_text` reads a UTF-8 file the user named (a world, a profile, a map): a file of
binary garbage or one that cannot be read is the caller's error class with one line that
names the file, not a ``UnicodeDecodeError``. It reads only regular files (not ``/dev/zero``,
a FIFO or a directory) and refuses a file over its size limit before reading it
(:mod:`d3dwa_bullet.limits`); YAML and JSON go through :mod:`d3dwa_bullet.loading`.

:func:`file_stem` makes a name read from a file or typed by the user (a world's ``name:``)
safe to use in a file name: it stays in its directory and within the file system's length.
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from d3dwa_bullet.errors import D3DWAError
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
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
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
