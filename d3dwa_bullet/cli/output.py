"""What commands write: destinations checked before any work starts, and strict JSON.

An episode, an evaluation or a recording may take minutes; a destination it cannot write
must be refused before the first step, not after the last. :func:`check_out_dir` and
:func:`check_out_file` raise :class:`ConfigError` naming the option and the path: a
directory that is a file, a path under a file, a location without write permission (or one
that cannot be created), a file name too long for the file system. They create the missing
directories the command would create anyway.

Text from outside (a robot's error details, a server's message, a field of a file) reaches
the terminal through :func:`printable`: its control characters are shown as escapes, never
sent, so no remote end can clear, retitle, recolour or ring the user's terminal.

``--json`` output is strict JSON (RFC 8259 has no NaN or Infinity): :func:`json_text` writes
non-finite floats, such as the minimum clearance of a world without obstacles, as ``null``.
"""

from __future__ import annotations

import json
import math
import os
import unicodedata
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.io import name_room


def _existing_ancestor(path: Path) -> Path:
    """The nearest of path, its parents, ... that exists (the current directory at worst)."""
    for candidate in (path, *path.parents):
        if os.path.lexists(candidate):
            return candidate
    return Path.cwd()


def _make_dir(directory: Path, option: str, shown: Path) -> None:
    """Create directory (and its parents), or ConfigError naming option and shown."""
    base = _existing_ancestor(directory)
    if not base.is_dir():
        raise ConfigError(f"{option} {shown}: {base} is a file, not a directory")
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ConfigError(f"{option} {shown}: cannot create {directory}: {err.strerror}") from err
    if not os.access(directory, os.W_OK | os.X_OK):
        raise ConfigError(f"{option} {shown}: cannot write in {directory} (permission denied)")


def check_out_dir(
    path: str | os.PathLike[str], option: str = "--out", subdirs: Iterable[str] = ()
) -> Path:
    """The output directory of a command, created and checked writable (with subdirs, the
    entries the command will make directories, such as logs/ and figures/, each refused if
    it is a symbolic link or a file)."""
    out = Path(path)
    if os.path.lexists(out) and not out.is_dir():
        raise ConfigError(f"{option} {out}: exists and is not a directory")
    _make_dir(out, option, out)
    for name in subdirs:
        sub = out / name
        if sub.is_symlink():  # files written into it would land wherever it points
            raise ConfigError(
                f"{option} {out}: {sub} is a symbolic link; a command writes only inside "
                f"{option} (remove the link, or use another directory)"
            )
        if os.path.lexists(sub) and not sub.is_dir():
            raise ConfigError(f"{option} {out}: {sub} exists and is not a directory")
    return out


def check_out_file(
    path: str | os.PathLike[str], option: str, suffixes: Iterable[str] | None = None
) -> Path:
    """An output file of a command: not a directory, its directory created and writable,
    and (with suffixes, lower case without the dot) a suffix the writer understands."""
    target = Path(path)
    directory = target.parent if str(target.parent) else Path(".")
    room, size = name_room(_existing_ancestor(directory)), len(os.fsencode(target.name))
    if size > room:
        raise ConfigError(
            f"{option} {_shown(target)}: the file name is {size} bytes, over the {room} this "
            "file system allows (a file is written under a temporary name first); give a "
            "shorter name"
        )
    try:
        is_dir = target.is_dir()
    except OSError as err:  # a path longer than the system's PATH_MAX
        raise ConfigError(f"{option} {_shown(target)}: {err.strerror}") from err
    if is_dir:
        raise ConfigError(f"{option} {target}: is a directory; give a file name")
    if suffixes is not None:
        allowed = sorted(set(suffixes))
        suffix = target.suffix.lower().lstrip(".")
        if suffix and suffix not in allowed:
            raise ConfigError(
                f"{option} {target}: unknown file type {target.suffix!r}; use one of "
                + ", ".join(f".{s}" for s in allowed)
            )
    _make_dir(directory, option, target)
    return target


def _shown(path: Path, most: int = 80) -> str:
    """path for a message, its middle cut out when it is longer than ``most`` characters."""
    text = str(path)
    return text if len(text) <= most else f"{text[: most // 2]}...{text[-most // 2 :]}"


def strict(value: Any) -> Any:
    """value with every non-finite float (NaN, +-inf) replaced by None, in nested
    dicts, lists and tuples (tuples become lists, as JSON has only arrays)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict(v) for v in value]
    return value


def json_text(value: Any, **kwargs: Any) -> str:
    """``json.dumps`` that never writes NaN or Infinity (see :func:`strict`)."""
    return json.dumps(strict(value), allow_nan=False, **kwargs)


def printable(text: str) -> str:
    """text with every control, format or unassigned character (ESC, BEL, CR, a bidi override,
    a lone surrogate, a line separator) written as its Python escape (``\\x1b``): what a
    command prints of a message that may come from a remote end."""
    return "".join(
        ch.encode("unicode_escape").decode("ascii") if _unsafe(ch) else ch for ch in text
    )


def _unsafe(ch: str) -> bool:
    category = unicodedata.category(ch)
    return category[0] == "C" or category in ("Zl", "Zp")
