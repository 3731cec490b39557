"""Which files of a bag may be opened: regular files only, the metadata read with a bound.

A bag is a ROS 1 ``.bag`` file, a bare ``.db3`` / ``.mcap`` file, or a ROS 2 directory whose
``metadata.yaml`` lists its data files. rosbags opens what it is given: a ``metadata.yaml``
that is a link to ``/dev/zero`` would be read without end, and a FIFO in place of a data
file would block the reader for ever. :func:`check_bag_files` runs before rosbags sees the
bag: the bag file, the metadata and every data file it lists must be regular files (a link
to one is fine), and the metadata is read through :func:`d3dwa_bullet.loading.load_yaml`
(bounded in size, depth and aliases). A missing file is left for rosbags to report.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping
from pathlib import Path, PurePath

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.loading import load_yaml

METADATA_FILE = "metadata.yaml"
"""The file of a ROS 2 bag directory that describes it (rosbag2)."""


def _check_regular(path: Path, what: str) -> None:
    """BagFormatError unless path (followed through links) is a regular file or missing."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise BagFormatError(f"{path}: cannot read: {err.strerror or err}") from err
    if not stat.S_ISREG(mode):
        kind = "a directory" if stat.S_ISDIR(mode) else "not a regular file"
        raise BagFormatError(f"{path}: {kind}; a bag's {what} must be a regular file")


def check_bag_files(path: Path) -> None:
    """BagFormatError naming the file unless every file of the bag at path that rosbags
    would open is a regular file (see the module docstring)."""
    if not path.is_dir():
        _check_regular(path, "file")
        return
    metadata = path / METADATA_FILE
    if not os.path.lexists(metadata):
        return
    _check_regular(metadata, "metadata")
    content = load_yaml(metadata, BagFormatError, "bag metadata file")
    info = content.get("rosbag2_bagfile_information") if isinstance(content, Mapping) else None
    names = info.get("relative_file_paths") if isinstance(info, Mapping) else None
    for name in names if isinstance(names, list) else []:
        _check_regular(path / PurePath(str(name)).name, "data file")  # as rosbags joins it
