"""Atomic file writes: a reader sees the old file or the new one, never half of either.

Each helper writes to a temporary file beside the target (same directory, so the rename
never crosses a file system), fsyncs it, then ``os.replace``s it over the target. If the
write fails, the temporary file is removed and the target is left as it was. The temporary
name starts with a dot and ends in ``.tmp``; it is created with mode 0666 minus the umask,
like an ordinary ``open(path, "w")``. The parent directory must exist.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, Protocol


class SavesFigure(Protocol):
    """Anything with matplotlib's ``Figure.savefig(file, **kw)`` (no matplotlib import here)."""

    def savefig(self, fname: Any, **kwargs: Any) -> Any: ...


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
