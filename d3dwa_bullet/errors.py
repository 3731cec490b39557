"""Typed errors. Every message names the file, field and value that was wrong."""

import errno
import os
from collections.abc import Iterable
from difflib import get_close_matches


class D3DWAError(Exception):
    """Base of every error this package raises on purpose."""


class ConfigError(D3DWAError, ValueError):
    """A parameter set has an impossible value (non-divisible rates, empty sets, ...)."""


class UnknownNameError(D3DWAError, KeyError):
    """An unknown world, method or profile name."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``did you mean 'X'? `` when one known name is close to name (a typo); '' otherwise: the
    start of an unknown name's hint, for every kind of name (methods, worlds, profiles)."""
    close = get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}? " if close else ""


class WorldFormatError(D3DWAError, ValueError):
    """A world file (native YAML, Gazebo SDF, map_server YAML/PGM) is malformed."""


class ScanError(D3DWAError, ValueError):
    """A scan or scan-point array cannot be used (NaN points, zero beams, bad geometry)."""


class ProfileError(D3DWAError, ValueError):
    """A randomisation profile is unknown, incomplete or has an out-of-range value."""


class EstimatorError(D3DWAError, ValueError):
    """The state estimator was fed NaN, a non-monotonic timestamp, or diverged."""


class CheckpointError(D3DWAError, ValueError):
    """A checkpoint is corrupt, truncated, of the wrong shape, action set or version."""


class BagFormatError(D3DWAError, ValueError):
    """A ROS bag is missing, unreadable, or lacks a topic the replay needs."""


class ResultsError(D3DWAError, ValueError):
    """A results directory is incomplete or from an incompatible version."""


class InstallError(D3DWAError, RuntimeError):
    """The installed package lacks a data folder it ships (worlds, urdf, policies, ...)."""


class TrainingError(D3DWAError, RuntimeError):
    """Training cannot go on (diverged weights, a replayed episode that does not match...)."""


class BackendError(D3DWAError, RuntimeError):
    """A backend cannot run: Ray missing, a Ray address that does not answer, a bad address."""


class BusyError(D3DWAError, RuntimeError):
    """An output directory is being written by another running command (it holds the lock)."""


class RobotLinkError(D3DWAError, RuntimeError):
    """The robot's API cannot be reached, answers wrongly or too late, or serves stale data."""


class WriteError(D3DWAError, OSError):
    """A file or directory cannot be written: the disk is full, the file too large, the
    directory read-only, or a file stands where a directory should. Still an OSError (errno,
    strerror and filename as the system gave them); its message is one line naming the path."""

    def __init__(self, path: object, err: OSError) -> None:
        reason = err.strerror or str(err)
        if err.errno == errno.ELOOP and os.path.islink(str(path)):  # refused by O_NOFOLLOW
            reason = "it is a symbolic link; only a regular file is written"
        super().__init__(err.errno, reason, str(path))

    def __str__(self) -> str:
        return f"{self.filename}: cannot write: {self.strerror}"


class ExternalMethodError(D3DWAError, RuntimeError):
    """A method from outside the package cannot be trusted: missing, of another interface
    version, raising, or answering with something that is not a finite, in-range answer."""
