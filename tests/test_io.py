"""Atomic writes: the new content or the old one, and no temporary file left either way."""

from __future__ import annotations

import errno
import os
import stat

import matplotlib.pyplot as plt
import pytest

from d3dwa_bullet.errors import WriteError
from d3dwa_bullet.io import (
    AppendFile,
    atomic_savefig,
    atomic_write_bytes,
    atomic_write_text,
    file_stem,
)
from d3dwa_bullet.limits import MAX_STEM_BYTES
from tests.support.file_limit import run_python_with_file_limit


class Boom(RuntimeError):
    pass


class FailingFigure:
    """Writes half a file, then fails, as a savefig that runs out of disk would."""

    def savefig(self, fh, **kwargs):
        fh.write(b"half a png")
        raise Boom("disk full")


def test_text_and_bytes_replace_the_file_and_leave_no_temporary(tmp_path):
    path = tmp_path / "page.md"
    path.write_text("old")
    assert atomic_write_text(path, "new ± text\n") == path
    assert path.read_bytes() == "new ± text\n".encode()
    atomic_write_bytes(tmp_path / "blob.bin", b"\x00\x01")
    assert (tmp_path / "blob.bin").read_bytes() == b"\x00\x01"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blob.bin", "page.md"]


def test_new_file_gets_the_mode_of_an_ordinary_write(tmp_path):
    atomic_write_text(tmp_path / "a.txt", "x")
    (tmp_path / "b.txt").write_text("x")
    mode = stat.S_IMODE(os.stat(tmp_path / "a.txt").st_mode)
    assert mode == stat.S_IMODE(os.stat(tmp_path / "b.txt").st_mode)


def test_failed_write_keeps_the_old_content_and_removes_the_temporary(tmp_path):
    path = tmp_path / "figure.png"
    path.write_bytes(b"old figure")
    with pytest.raises(Boom):
        atomic_savefig(FailingFigure(), path)
    assert path.read_bytes() == b"old figure"
    assert [p.name for p in tmp_path.iterdir()] == ["figure.png"]


def test_failed_write_of_a_new_file_leaves_nothing(tmp_path):
    with pytest.raises(TypeError):
        atomic_write_bytes(tmp_path / "x.bin", "not bytes")  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_savefig_takes_the_format_from_the_suffix(tmp_path):
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [1, 0])
    try:
        atomic_savefig(fig, tmp_path / "f.png", dpi=50)
        atomic_savefig(fig, tmp_path / "f.svg")
    finally:
        plt.close(fig)
    assert (tmp_path / "f.png").read_bytes().startswith(b"\x89PNG")
    assert b"<svg" in (tmp_path / "f.svg").read_bytes()[:500]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png", "f.svg"]


@pytest.mark.parametrize("name", ["TS1", "R1-style-s2147483650", "tiny", "my world", "wörld"])
def test_an_ordinary_name_is_its_own_file_stem(name):
    assert file_stem(name) == name


@pytest.mark.parametrize(
    "name", ["../../escape", "/etc/passwd", "a\\b", "line\nbreak", ".", "..", "", "x" * 300]
)
def test_a_name_that_is_no_file_name_becomes_one_in_its_directory(name, tmp_path):
    stem = file_stem(name)
    assert "/" not in stem and "\\" not in stem and "\n" not in stem and stem not in (".", "..")
    assert len(stem.encode()) <= MAX_STEM_BYTES.value
    assert (tmp_path / f"{stem}_time.png").parent == tmp_path
    atomic_write_text(tmp_path / f"{stem}_time.png", "x")  # the file system takes it


def test_cut_names_stay_distinct_and_whole_characters():
    a, b = "é" * 200 + "a", "é" * 200 + "b"
    assert file_stem(a) != file_stem(b)
    assert len(file_stem(a).encode()) <= MAX_STEM_BYTES.value
    assert file_stem(a).startswith("é" * 10)  # cut between characters, not inside one
    assert file_stem("a/b") != file_stem("a_b") == "a_b"


# A file system that refuses a write: one error naming the path, the old file kept ---------


def test_a_write_past_the_file_size_limit_names_the_file_and_keeps_the_old_one(tmp_path):
    path = tmp_path / "table.md"
    path.write_text("old table\n")
    done = run_python_with_file_limit(
        "from d3dwa_bullet.io import atomic_write_bytes\n"
        "from d3dwa_bullet.errors import WriteError\n"
        "try:\n"
        f"    atomic_write_bytes({str(path)!r}, b'x' * 5000)\n"
        "except WriteError as err:\n"
        "    print(err)\n",
        limit=1000,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"{path}: cannot write: File too large\n"
    assert path.read_text() == "old table\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.md"]


@pytest.mark.parametrize(
    ("code", "reason"),
    [(errno.ENOSPC, "No space left on device"), (errno.EROFS, "Read-only file system")],
)
def test_a_refused_write_is_one_write_error_naming_the_target(tmp_path, monkeypatch, code, reason):
    path = tmp_path / "meta.json"
    path.write_text("{}")

    def refuse(src, dst):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(WriteError) as caught:
        atomic_write_text(path, '{"new": 1}')
    assert str(caught.value) == f"{path}: cannot write: {reason}"
    assert isinstance(caught.value, OSError) and caught.value.errno == code
    assert path.read_text() == "{}" and [p.name for p in tmp_path.iterdir()] == ["meta.json"]


def test_a_file_where_the_directory_should_be_is_a_write_error(tmp_path):
    (tmp_path / "logs").write_text("a file, not a directory")
    with pytest.raises(WriteError, match=r"/logs/x\.npz: cannot write: Not a directory$"):
        atomic_write_bytes(tmp_path / "logs" / "x.npz", b"log")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only directory")
def test_a_read_only_directory_is_a_write_error(tmp_path):
    tmp_path.chmod(0o500)
    try:
        with pytest.raises(WriteError, match="cannot write: Permission denied$"):
            atomic_write_text(tmp_path / "a.txt", "x")
    finally:
        tmp_path.chmod(0o700)


def test_an_append_past_the_file_size_limit_leaves_the_file_as_it_was(tmp_path):
    path = tmp_path / "results.csv"
    path.write_bytes(b"a,b\n1,2\n")
    done = run_python_with_file_limit(
        "from d3dwa_bullet.io import AppendFile\n"
        "from d3dwa_bullet.errors import WriteError\n"
        f"with AppendFile({str(path)!r}) as fh:\n"
        "    fh.write(b'3,4\\n')\n"
        "    try:\n"
        "        fh.write(b'5,' + b'6' * 100 + b'\\n')\n"  # past the limit mid-record
        "    except WriteError as err:\n"
        "        print(err)\n",
        limit=40,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"{path}: cannot write: File too large\n"
    assert path.read_bytes() == b"a,b\n1,2\n3,4\n"  # the record before it, and no half row


def test_appending_never_goes_through_a_link_or_into_a_fifo(tmp_path):
    outside = tmp_path / "outside.txt"
    outside.write_text("not yours\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").symlink_to(outside)
    with pytest.raises(WriteError, match="results.csv: cannot write: it is a symbolic link"):
        AppendFile(out / "results.csv")
    assert outside.read_text() == "not yours\n"
    os.mkfifo(out / "metrics.jsonl")
    with pytest.raises(WriteError, match="metrics.jsonl: cannot write: "):
        AppendFile(out / "metrics.jsonl")  # no reader: refused at once, not waited on
