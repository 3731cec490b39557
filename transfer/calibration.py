"""``d3dwa calibrate``: a randomisation profile fitted to a robot's own bags.

The lidar estimates come from :mod:`transfer.calibrate_scans`, odometry and gyro from
:mod:`transfer.calibrate_motion`; every parameter the bags cannot inform keeps the base
profile's distribution. The file is a normal profile (``randomization.profiles``): every
parameter carries a comment saying how it was estimated or why it was kept, and an
informational ``sensor:`` section records the scanner's beam count, field of view and scan
rate, which the simulated lidar does not take from a profile. The text is checked with the
profile parser, then written atomically, only at the end: a failure leaves no file.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import yaml

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.loading import load_yaml, parse_yaml
from d3dwa_bullet.sim.noise_config import CONFIG_GROUPS, TABLE_PARAMS
from d3dwa_bullet.sim.scan import Pose2D
from randomization.profiles import PROFILE_VERSION, load_profile, profile_from_dict
from transfer.bag_reader import BagData, read_bag
from transfer.calibrate_motion import MotionCalibration, calibrate_motion
from transfer.calibrate_scans import MIN_PHANTOMS, ScanCalibration, calibrate_scans
from transfer.topics import TopicMap

#: Why a parameter no bag can inform is kept from the base.
NOT_OBSERVABLE = {
    "slip": "slip is not separable from a wheel-radius error in odometry (a fitted radius "
    "error already holds the mean slip)",
    "latency": "command latency needs commands and the motion they cause; not estimated",
    "physics": "friction, mass and motor torque are not observable in scans, odometry or IMU",
    "pose_fix": "localisation error needs ground truth; not estimated",
}
LIDAR_KEPT = {
    "lidar.spurious_min": f"fewer than {MIN_PHANTOMS} phantom returns to estimate their range",
    "lidar.spurious_max": f"fewer than {MIN_PHANTOMS} phantom returns to estimate their range",
    "lidar.dropout_kinds": "no dropout seen to take the mix from",
    "lidar.dropout_sector_scale": "no dropout seen",
    "lidar.dropout_sector_kinds": "no dropout seen",
    "lidar.dropout_prob": "no beam valid in consecutive scans",
    "lidar.spurious_prob": "no beam valid in consecutive scans",
}
SENSOR_COMMENT = (
    "informational: the simulated lidar (d3dwa_bullet.sim.lidar.LidarParams, 481 beams over "
    "240 deg, one scan per 0.1 s control step) does not take these from a profile"
)


@dataclass
class CalibrationResult:
    profile: Path
    scans: int
    estimated: list[str]
    kept_from_base: list[str]
    notes: list[str] = field(default_factory=list)
    scan_fit: ScanCalibration | None = None
    motion_fit: MotionCalibration | None = None

    def summary(self) -> dict[str, Any]:
        """The ``--json`` output."""
        return {
            "profile": str(self.profile),
            "scans": self.scans,
            "estimated": self.estimated,
            "kept_from_base": self.kept_from_base,
        }


HEADER = "# Calibrated by `d3dwa calibrate`"
"""The first line of every profile ``calibrate`` writes: what it may replace without --force."""


def check_profile_path(out: str | Path, force: bool = False) -> Path:
    """The output path, refused (ConfigError) unless a .yaml/.yml file in an existing folder
    that is new, or a profile written by ``calibrate`` (its first line is HEADER), or any
    regular file with ``force``: a training config or a hand-written profile is not replaced
    by mistake."""
    path = Path(out)
    if path.suffix not in (".yaml", ".yml"):
        raise ConfigError(f"--out {path}: a profile file must end in .yaml or .yml")
    if path.is_dir():
        raise ConfigError(f"--out {path}: is a directory; name the profile file")
    if not path.parent.is_dir():
        raise ConfigError(f"--out {path}: folder {path.parent} does not exist")
    if path.exists() or path.is_symlink():
        if not path.is_file():
            raise ConfigError(f"--out {path}: exists and is not a regular file; name another")
        with path.open("rb") as fh:
            ours = fh.readline(len(HEADER) + 1).startswith(HEADER.encode())
        if not (ours or force):
            raise ConfigError(
                f"--out {path}: exists and is not a profile written by `d3dwa calibrate`; "
                "name another file, or pass --force to replace it"
            )
    return path


def comment_text(text: object) -> str:
    """``text`` safe inside a one-line ``#`` comment: control characters (a newline in a
    bag's folder name) escaped, so no name can end the comment and add YAML to the file."""
    return "".join(
        c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in str(text)
    )


def _flow(value: Any) -> str:
    text = yaml.safe_dump(value, default_flow_style=True, width=1 << 30).strip()
    return text.removesuffix("...").strip()


def _one_line(text: str) -> str:
    return " ".join(text.split())


def calibrate(
    bag_paths: list[str | Path],
    out: str | Path,
    *,
    base: str | Path = "real",
    name: str | None = None,
    topics: TopicMap | None = None,
    mount: Pose2D | None = None,
    force: bool = False,
) -> CalibrationResult:
    """Fit a profile to ``bag_paths`` on top of ``base`` and write it to ``out``.

    Raises ``ConfigError`` for a bad ``out`` (also an existing file that calibrate did not
    write, unless ``force``), ``ProfileError`` for a bad base,
    ``BagFormatError`` for an unreadable bag, one without scans, or scans too few to
    estimate anything; in each case nothing is written.
    """
    path = check_profile_path(out, force)
    base_profile = load_profile(base)
    raw_base = load_yaml(base_profile.source, ConfigError, "profile YAML")
    bags: list[BagData] = [read_bag(p, topics=topics, mount=mount) for p in bag_paths]
    scan_fit = calibrate_scans(bags)
    motion_fit = calibrate_motion(bags)
    estimates = {**scan_fit.estimates, **motion_fit.estimates}
    kept_why = {**LIDAR_KEPT, **motion_fit.kept}
    if "lidar.dropout_sector_kinds" in estimates:
        kept_why["lidar.dropout_kinds"] = (
            "superseded by dropout_sector_kinds (the simulator ignores it while that table is set)"
        )
    base_name = base_profile.name
    name = name or path.stem

    lines = [
        f"{HEADER} from {len(bags)} bag(s), {scan_fit.scans} scans:",
        *(f"#   {comment_text(b.path)}" for b in bags),
        f"# Base profile {base_name!r} ({comment_text(base_profile.source)}). Each parameter "
        "says how it was",
        f"# estimated, or why it keeps the base's value. Use it as --noise {comment_text(path)}.",
        f"name: {_flow(name)}",
        f"version: {PROFILE_VERSION}",
        "description: "
        + _flow(f"{name}: calibrated from {scan_fit.scans} scans on top of {base_name!r}"),
        f"sensor:  # {SENSOR_COMMENT}",
    ]
    sensor_how = {
        "beams": "beams per scan",
        "fov_deg": "angle_max - angle_min",
        "scan_rate_hz": "1 / median interval between scans",
    }
    for key, value in scan_fit.sensor.items():
        note = f"  # estimated: {sensor_how[key]}" if key in sensor_how else ""
        lines.append(f"  {key}: {_flow(value)}{note}")
    lines.append("params:")
    estimated = [f"sensor.{k}" for k in sensor_how]
    kept: list[str] = []
    for group, cls in CONFIG_GROUPS.items():
        lines.append(f"  {group}:")
        for f in fields(cls):
            key = f"{group}.{f.name}"
            if key in estimates:
                est = estimates[key]
                comment = f"estimated: {_one_line(est.how)}"
                estimated.append(key)
                value = est.value
            else:
                why = NOT_OBSERVABLE.get(group) or kept_why.get(key, "not estimated")
                value = raw_base["params"][group].get(f.name)
                if (group, f.name) in TABLE_PARAMS and value is None:
                    lines.append(f"    # {f.name}: off ({why})")
                    continue
                comment = f"kept from base {base_name!r}: {_one_line(why)}"
                kept.append(key)
            if f.name == "dropout_sector_kinds":
                lines.append(f"    {f.name}:  # {comment}")
                lines.append(
                    "      # rows: sectors right to left; NaN, +inf, -inf, 0.0, out of range"
                )
                lines += [f"      - {_flow(row)}" for row in value]
            else:
                lines.append(f"    {f.name}: {_flow(value)}  # {comment}")
    text = "\n".join(lines) + "\n"
    profile_from_dict(parse_yaml(text, ConfigError, str(path)), str(path))  # or nothing is written
    atomic_write_text(path, text)
    return CalibrationResult(
        path, scan_fit.scans, estimated, kept, scan_fit.notes, scan_fit, motion_fit
    )
