"""Special files inside a bag are refused, not read: a metadata.yaml that is a link to
/dev/zero (read without end), a FIFO in place of a data file or of the bag (a reader would
wait for ever), a metadata file past the size limit. One BagFormatError naming the file.

Each bag with a special file is read in a child process of bounded memory and time: were
the check gone, the test would fail, not hang the suite or fill the machine's memory (a
reader blocked in sqlite's open of a FIFO never returns to Python for an alarm to stop it).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from d3dwa_bullet.errors import BagFormatError
from tests.support.file_limit import REPO, error_lines
from transfer.bag_files import check_bag_files
from transfer.bag_writer import BagRecorder

MS = 1_000_000


def in_child(code: str) -> subprocess.CompletedProcess[str]:
    """Run python code with 1 GiB of address space, killed after 60 s."""
    prelude = "import resource\nresource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))\n"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    try:
        return subprocess.run(
            [sys.executable, "-c", prelude + code],
            capture_output=True, text=True, env=env, timeout=60,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail("reading the bag hung (still running after 60 s)")


def read_bag_error(bag: Path) -> str:
    """The BagFormatError read_bag(bag) raises in a child process."""
    done = in_child(
        "from d3dwa_bullet.errors import BagFormatError\n"
        "from transfer.bag_reader import read_bag\n"
        "try:\n"
        f"    read_bag({str(bag)!r})\n"
        "except BagFormatError as err:\n"
        "    print(err)\n"
    )
    assert done.returncode == 0 and done.stdout, done.stderr[-2000:]
    return done.stdout.rstrip("\n")


@pytest.fixture(params=["sqlite3", "mcap"])
def ros2_bag(request, tmp_path: Path) -> Path:
    """A ROS 2 bag directory with one odometry message."""
    path = tmp_path / "bag"
    with BagRecorder(path, storage=request.param) as rec:
        rec.write_odometry(MS, (0, 0, 0), (0, 0))
    return path


def data_file(bag: Path) -> Path:
    (data,) = [p for p in bag.iterdir() if p.suffix in (".db3", ".mcap")]
    return data


def test_a_metadata_file_linked_to_dev_zero_is_refused_at_once(ros2_bag):
    metadata = ros2_bag / "metadata.yaml"
    metadata.unlink()
    metadata.symlink_to("/dev/zero")
    assert read_bag_error(ros2_bag) == (
        f"{metadata}: not a regular file; a bag's metadata must be a regular file"
    )


def test_a_fifo_in_place_of_a_data_file_is_refused_without_waiting(ros2_bag):
    data = data_file(ros2_bag)
    data.unlink()
    os.mkfifo(data)
    assert read_bag_error(ros2_bag) == (
        f"{data}: not a regular file; a bag's data file must be a regular file"
    )


def test_a_fifo_as_the_bag_is_refused_without_waiting(tmp_path):
    fifo = tmp_path / "run.bag"
    os.mkfifo(fifo)
    assert (
        read_bag_error(fifo) == f"{fifo}: not a regular file; a bag's file must be a regular file"
    )


def test_a_metadata_file_past_the_size_limit_is_refused_before_reading(ros2_bag):
    metadata = ros2_bag / "metadata.yaml"
    os.truncate(metadata, 64 * 2**20)  # sparse: 64 MiB of nothing on disk
    with pytest.raises(BagFormatError, match=f"^{metadata}: .* is over the limit of"):
        check_bag_files(ros2_bag)


def test_a_directory_named_as_a_data_file_is_refused(ros2_bag):
    data = data_file(ros2_bag)
    data.unlink()
    data.mkdir()
    with pytest.raises(BagFormatError, match=f"^{data}: a directory; "):
        check_bag_files(ros2_bag)


def test_a_good_bag_passes_and_calibrate_names_a_fifo_in_one_line(ros2_bag, tmp_path):
    check_bag_files(ros2_bag)  # the recorder's own bag: nothing refused
    data = data_file(ros2_bag)
    data.unlink()
    os.mkfifo(data)
    argv = ["calibrate", str(ros2_bag), "--out", str(tmp_path / "p.yaml")]
    done = in_child(
        f"import sys\nfrom d3dwa_bullet.cli.app import main\nsys.exit(main({argv!r}))\n"
    )
    assert done.returncode == 2 and error_lines(done.stderr) == [
        f"d3dwa: error: {data}: not a regular file; a bag's data file must be a regular file"
    ], done.stderr[-2000:]
    assert not (tmp_path / "p.yaml").exists()
