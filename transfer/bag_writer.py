"""Record simulated episodes as ROS bags with the Kachaka bridge's topic names and types.

Precision: ``sensor_msgs/LaserScan`` stores ``ranges``, ``angle_min``, ``angle_increment``,
``range_min`` and ``range_max`` as float32, so a recorded scan is the simulated one rounded
to float32. For a replay to reproduce the simulator's observations bit for bit, the
simulator should build its observation from ``quantize_scan(scan)``, the scan it records.
Everything else is float64 in ROS and round-trips exactly: odometry x, y, v, w, gyro rate,
commands, planner parameters, and yaw too (``quaternion_from_yaw`` picks the quaternion
whose decoding gives back the same float64, for yaw in (-pi, pi]).

A failure inside ``with BagRecorder(...)`` still closes the bag properly: what was written
up to the failure stays readable.

Storage and version: the storage follows the path's suffix unless given (``resolve_storage``:
``x.mcap`` is an MCAP bag, ``x.bag`` a ROS 1 bag, anything else a sqlite3 bag; a suffix that
contradicts an explicit storage is refused, never a sqlite3 bag named ``x.mcap``). A ROS 2
bag is a directory (rosbags names its one data file ``<dir name>.db3`` or ``.mcap``).
ROS 2 bags are written in rosbag2 metadata version ``DEFAULT_BAG_VERSION`` = 8, the one ROS 2
Humble reads: Humble's metadata decoder reads each topic's ``offered_qos_profiles`` as one
YAML string, which version 8 writes, while version 9 (what Jazzy and later write) stores a
YAML list there, and Humble refuses the whole bag ("bad conversion"). Versions 8 and 9 are
what rosbags' writer produces (``BAG_VERSIONS``); pass ``version=9`` for Jazzy-only tools.
"""

from __future__ import annotations

import shutil
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, cast

import numpy as np

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.robot import IMU_MOUNT, LIDAR_MOUNT
from d3dwa_bullet.sim.scan import LaserScan
from transfer.ros_messages import MessageBuilder, default_typestore
from transfer.topics import (
    FLOAT64_ARRAY,
    IMU,
    LASER_SCAN,
    ODOMETRY,
    POSE_STAMPED,
    TF_MESSAGE,
    TWIST,
    TopicMap,
)

Storage = Literal["sqlite3", "mcap", "ros1"]
STORAGES: tuple[Storage, ...] = ("sqlite3", "mcap", "ros1")
#: The storage a path's suffix names (any other suffix: a sqlite3 ROS 2 bag directory).
SUFFIX_STORAGE: dict[str, Storage] = {".mcap": "mcap", ".bag": "ros1", ".db3": "sqlite3"}
#: rosbag2 metadata versions rosbags' writer can produce.
BAG_VERSIONS = (8, 9)
#: The version ROS 2 Humble reads (module docstring); later distributions read it too.
DEFAULT_BAG_VERSION = 8


def resolve_storage(
    path: str | Path, storage: str | None = None, *, option: str = "storage"
) -> Storage:
    """The storage of a bag written to path: ``storage`` if given, else the suffix's
    (``SUFFIX_STORAGE``), else sqlite3. BagFormatError for an unknown storage, or one the
    suffix contradicts; ``option`` is how the messages name the storage setting (the CLI
    passes ``--storage``)."""
    path = Path(path)
    implied = SUFFIX_STORAGE.get(path.suffix)
    if storage is None:
        return implied or "sqlite3"
    if storage not in STORAGES:
        raise BagFormatError(f"{path}: unknown {option} {storage!r}; use {', '.join(STORAGES)}")
    if implied is not None and implied != storage:
        raise BagFormatError(
            f"{path}: the suffix {path.suffix!r} names a {implied} bag, not {option} {storage!r}; "
            f"rename the bag or drop {option}"
        )
    if storage == "ros1" and implied is None:
        raise BagFormatError(f"{path}: a ROS 1 bag ({option} 'ros1') must end in '.bag'")
    return cast(Storage, storage)


def check_bag_version(
    version: int | None, storage: Storage, path: str | Path, *, option: str = "version"
) -> int | None:
    """The rosbag2 metadata version to write: ``DEFAULT_BAG_VERSION`` when None, None for a
    ROS 1 bag (which has no such version). BagFormatError for a version rosbags cannot
    write, or one given for a ROS 1 bag; ``option`` names the setting in the messages."""
    if storage == "ros1":
        if version is not None:
            raise BagFormatError(
                f"{path}: {option} {version} is a ROS 2 bag format version; a ROS 1 bag has none"
            )
        return None
    if version is None:
        return DEFAULT_BAG_VERSION
    if version not in BAG_VERSIONS:
        raise BagFormatError(
            f"{path}: {option} {version} cannot be written; use "
            f"{' or '.join(map(str, BAG_VERSIONS))} ({DEFAULT_BAG_VERSION}: read by ROS 2 Humble and "
            f"later, 9: by Jazzy and later)"
        )
    return int(version)


@dataclass(frozen=True)
class Frames:
    """tf frame names written into headers and transforms."""

    odom: str = "odom"
    base: str = "base_link"
    lidar: str = "lidar_link"
    imu: str = "imu_link"


#: Kachaka lidar and IMU positions in base_link, m (d3dwa_bullet.robot).
LIDAR_MOUNT_XYZ = LIDAR_MOUNT
IMU_MOUNT_XYZ = IMU_MOUNT


def quantize_scan(scan: LaserScan) -> LaserScan:
    """The scan as a bag stores it: every LaserScan float field rounded to float32."""

    def f32(x: float) -> float:
        return float(np.float32(x))

    return LaserScan(
        angle_min=f32(scan.angle_min),
        angle_increment=f32(scan.angle_increment),
        ranges=scan.ranges.astype(np.float32).astype(np.float64),
        range_min=f32(scan.range_min),
        range_max=f32(scan.range_max),
        stamp_ns=scan.stamp_ns,
    )


class BagRecorder:
    """Write a bag step by step; a context manager.

    path: a ROS 2 bag directory (storage "sqlite3" or "mcap"), or a ROS 1 ``.bag`` file
    (storage "ros1"); storage None follows the suffix (``resolve_storage``). version: the
    rosbag2 metadata version of a ROS 2 bag (None: ``DEFAULT_BAG_VERSION``, which ROS 2
    Humble reads). An existing bag is refused unless overwrite=True.
    goal: (x, y) in the odometry frame, written once with the first step.
    Timestamps are integer nanoseconds; every message's header stamp and receive time are
    the step's t_ns (a scan keeps its own stamp_ns when it is non-zero).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        storage: Storage | None = None,
        version: int | None = None,
        typestore: Any = None,
        topics: TopicMap | None = None,
        frames: Frames | None = None,
        lidar_mount: tuple[float, float, float] = LIDAR_MOUNT_XYZ,
        imu_mount: tuple[float, float, float] = IMU_MOUNT_XYZ,
        goal: tuple[float, float] | np.ndarray | None = None,
        overwrite: bool = False,
    ) -> None:
        self.path = Path(path)
        self.storage = resolve_storage(self.path, storage)
        self.version = check_bag_version(version, self.storage, self.path)
        """rosbag2 metadata version (None for a ROS 1 bag)."""
        self.ros1 = self.storage == "ros1"
        self.typestore = typestore or default_typestore(self.ros1)
        self.topics = topics or TopicMap()
        self.frames = frames or Frames()
        self.lidar_mount = tuple(float(v) for v in lidar_mount)
        self.imu_mount = tuple(float(v) for v in imu_mount)
        self.goal = None if goal is None else np.asarray(goal, dtype=np.float64).reshape(2)
        self.overwrite = overwrite
        self._writer: Any = None
        self._connections: dict[str, Any] = {}
        self._started = False
        self.created = False
        """True once this recorder has created its bag (``discard`` only removes such a bag)."""
        self.build = MessageBuilder(self.typestore, self.ros1)
        """Builds this recorder's messages (its typestore, its ROS version)."""
        self.counts: dict[str, int] = {}

    def __enter__(self) -> BagRecorder:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
            return
        with suppress(Exception):  # keep what was written; the original error propagates
            self.close()

    def open(self) -> None:
        # rosbags takes ~0.1 s to import; every `d3dwa` command imports transfer, few write a bag.
        from rosbags.rosbag1 import Writer as Writer1
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Writer2

        if self.path.exists():
            if not self.overwrite:
                raise BagFormatError(
                    f"{self.path}: bag exists; refusing to overwrite (overwrite=True)"
                )
            self._remove_existing()
        try:
            if self.ros1:
                self._writer = Writer1(self.path)
            else:
                plugin = StoragePlugin.MCAP if self.storage == "mcap" else StoragePlugin.SQLITE3
                version = cast(Literal[8, 9], self.version)  # checked: one of BAG_VERSIONS
                self._writer = Writer2(self.path, version=version, storage_plugin=plugin)
            self._writer.open()
        except Exception as err:
            raise BagFormatError(f"{self.path}: cannot create bag: {err}") from err
        self.created = True

    def _remove_existing(self) -> None:
        p = self.path
        if p.is_dir() and (p / "metadata.yaml").exists():
            shutil.rmtree(p)
        elif p.is_file() and p.suffix in (".bag", ".db3", ".mcap"):
            p.unlink()
        else:
            raise BagFormatError(f"{p}: exists and does not look like a bag; not deleting it")

    def close(self) -> None:
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()

    def discard(self) -> None:
        """Close and delete the bag this recorder created (e.g. one left empty by a failure)."""
        with suppress(Exception):
            self.close()
        if self.created and self.path.exists():
            with suppress(BagFormatError, OSError):
                self._remove_existing()
        self.created = False

    def _connection(self, topic: str, msgtype: str) -> Any:
        conn = self._connections.get(topic)
        if conn is None:
            conn = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
            self._connections[topic] = conn
        return conn

    def _write(self, topic: str | None, msgtype: str, t_ns: int, msg: Any) -> None:
        if topic is None:
            return
        if self._writer is None:
            raise BagFormatError(f"{self.path}: recorder is not open")
        ts = self.typestore
        data = ts.serialize_ros1(msg, msgtype) if self.ros1 else ts.serialize_cdr(msg, msgtype)
        self._writer.write(self._connection(topic, msgtype), int(t_ns), data)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def write_message(self, topic: str, msgtype: str, t_ns: int, msg: Any) -> None:
        """Any message of the recorder's typestore (build it with ``self.message``)."""
        self._start(t_ns)
        self._write(topic, msgtype, t_ns, msg)

    def write_raw(self, topic: str, msgtype: str, t_ns: int, data: bytes) -> None:
        """Already serialised bytes, written as they are (tests use it for corrupt messages)."""
        if self._writer is None:
            raise BagFormatError(f"{self.path}: recorder is not open")
        self._writer.write(self._connection(topic, msgtype), int(t_ns), data)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def message(self, msgtype: str, **fields: Any) -> Any:
        """A message instance of the recorder's typestore; ``header``s via ``self.header``."""
        return self.build.message(msgtype, **fields)

    def header(self, stamp_ns: int, frame: str) -> Any:
        """A std_msgs/Header for this recorder's ROS version."""
        return self.build.header(stamp_ns, frame)

    def _start(self, t_ns: int) -> None:
        if self._started:
            return
        self._started = True
        f = self.frames
        static = [
            self.build.transform(t_ns, f.base, f.lidar, self.lidar_mount, 0.0),
            self.build.transform(t_ns, f.base, f.imu, self.imu_mount, 0.0),
        ]
        self._write(self.topics.tf_static, TF_MESSAGE, t_ns, self.build.tf_message(static))
        if self.goal is not None:
            self.write_goal(t_ns, self.goal)

    def write_goal(self, t_ns: int, goal: tuple[float, float] | np.ndarray) -> None:
        """geometry_msgs/PoseStamped at (x, y) m in the odometry frame."""
        x, y = (float(v) for v in np.asarray(goal, dtype=np.float64).reshape(2))
        msg = self.build.goal(t_ns, self.frames.odom, x, y)
        self._write(self.topics.goal, POSE_STAMPED, t_ns, msg)

    def write_scan(self, t_ns: int, scan: LaserScan) -> None:
        """sensor_msgs/LaserScan in the lidar frame (ranges rounded to float32)."""
        self._start(t_ns)
        msg = self.build.scan(scan.stamp_ns or t_ns, self.frames.lidar, scan)
        self._write(self.topics.scan, LASER_SCAN, t_ns, msg)

    def write_odometry(
        self,
        t_ns: int,
        pose: tuple | np.ndarray,
        twist: tuple | np.ndarray,
        *,
        wheel: bool = False,
        stamp_ns: int | None = None,
    ) -> None:
        """nav_msgs/Odometry: pose (x, y, yaw) in odom, twist (v, w) in base_link.

        stamp_ns: header stamp if it differs from the receive time t_ns (latency, clock tests).
        """
        self._start(t_ns)
        stamp = t_ns if stamp_ns is None else stamp_ns
        msg = self.build.odometry(stamp, self.frames.odom, self.frames.base, pose, twist)
        topic = self.topics.wheel_odometry if wheel else self.topics.odometry
        self._write(topic, ODOMETRY, t_ns, msg)

    def write_tf(self, t_ns: int, pose: tuple | np.ndarray) -> None:
        """tf2_msgs/TFMessage with odom -> base_link at pose (x, y, yaw)."""
        self._start(t_ns)
        x, y, yaw = (float(v) for v in pose)
        tf = self.build.transform(t_ns, self.frames.odom, self.frames.base, (x, y, 0.0), yaw)
        self._write(self.topics.tf, TF_MESSAGE, t_ns, self.build.tf_message([tf]))

    def write_imu(self, t_ns: int, gyro_w: float, *, stamp_ns: int | None = None) -> None:
        """sensor_msgs/Imu with angular_velocity.z = gyro_w, rad/s; no orientation estimate."""
        self._start(t_ns)
        stamp = t_ns if stamp_ns is None else stamp_ns
        msg = self.build.imu(stamp, self.frames.imu, gyro_w)
        self._write(self.topics.imu, IMU, t_ns, msg)

    def write_cmd(self, t_ns: int, cmd: tuple | np.ndarray) -> None:
        """geometry_msgs/Twist (v m/s, w rad/s)."""
        self._start(t_ns)
        v, w = (float(u) for u in cmd)
        self._write(self.topics.cmd_vel, TWIST, t_ns, self.build.twist(v, w))

    def write_params(self, t_ns: int, params: tuple | np.ndarray) -> None:
        """std_msgs/Float64MultiArray [wp, wc, ws, tau, action_index]."""
        self._start(t_ns)
        data = np.asarray(params, dtype=np.float64).reshape(-1)
        if data.size != 5:
            raise BagFormatError(
                f"{self.path}: planner params need [wp, wc, ws, tau, action_index], got {data.size} values"
            )
        msg = self.build.planner_params(data)
        self._write(self.topics.planner_params, FLOAT64_ARRAY, t_ns, msg)

    def write_step(
        self,
        t_ns: int,
        scan: LaserScan | None,
        odom_pose: tuple | np.ndarray,
        odom_twist: tuple | np.ndarray,
        wheel_pose: tuple | np.ndarray | None = None,
        wheel_twist: tuple | np.ndarray | None = None,
        gyro_w: float | None = None,
        cmd: tuple | np.ndarray | None = None,
        params: tuple | np.ndarray | None = None,
    ) -> None:
        """One control step: odometry (+ tf odom -> base_link), wheel odometry, IMU, scan,
        command and planner parameters, all at t_ns. None skips that message."""
        self._start(t_ns)
        self.write_odometry(t_ns, odom_pose, odom_twist)
        self.write_tf(t_ns, odom_pose)
        if wheel_pose is not None and wheel_twist is not None:
            self.write_odometry(t_ns, wheel_pose, wheel_twist, wheel=True)
        if gyro_w is not None:
            self.write_imu(t_ns, gyro_w)
        if scan is not None:
            self.write_scan(t_ns, scan)
        if cmd is not None:
            self.write_cmd(t_ns, cmd)
        if params is not None:
            self.write_params(t_ns, params)
