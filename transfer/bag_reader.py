"""Read a ROS 1 or ROS 2 bag into plain numpy time series.

Opens ROS 1 ``.bag`` files, ROS 2 bag directories, and bare ROS 2 ``.db3`` / ``.mcap`` files
with ``rosbags.highlevel.AnyReader``. Nothing here needs a ROS installation.

Replay clock
------------
Every series is put on ONE clock, chosen per bag:

* ``header`` (preferred): the messages' ``header.stamp``, i.e. when the data was measured.
  Used when every message of the streams that get aligned (scan, the pose-source
  odometry and the IMU, if present) has a non-zero stamp and the stamps of each stream
  never decrease.
* ``receive``: the bag's receive (record) time, when any of those streams has a zero stamp
  (drivers that leave the header empty) or stamps that go backwards (several publishers
  on one topic, clock resets). A per-bag choice, never per message, so two streams are
  never compared across clocks.

Headerless messages (``Twist`` commands, planner parameters) only have a receive time. On
the header clock they are shifted by the median (header stamp - receive time) of the scan
topic, so a bag whose stamps are simulation time while its receive times are wall time
still lines commands up with scans. ``read_bag(..., clock="header"|"receive")`` forces a
clock. ``BagData.clock`` and ``BagData.notes`` say which clock was used and why.

Alignment: odometry is linearly interpolated to scan times (yaw through the shortest
angular difference, i.e. unwrapped, then wrapped to (-pi, pi]); a scan before the first or
after the last odometry sample has no pose and is skipped by the replay with that reason.
At a scan time equal to an odometry stamp the odometry values are returned bit for bit.
"""

from __future__ import annotations

import math
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from d3dwa_bullet.errors import BagFormatError, ScanError
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from transfer.topics import LASER_SCAN, TopicMap, TopicResolution, resolve_topics
from transfer.transforms import (
    TransformTree,
    matrix_from_transform,
    pose2d_from_matrix,
    wrap_angles,
    yaw_from_quaternion,
)

Clock = Literal["auto", "header", "receive"]

#: Frames tried, in order, as the robot body frame when looking up the lidar mount.
BASE_FRAMES = ("base_link", "base_footprint")
#: Kachaka's lidar mount in base_link (SPEC section 3), used when a bag has no transform.
KACHAKA_LIDAR_MOUNT = Pose2D(0.156, 0.0, 0.0)

REJECT_ZERO_BEAMS = "zero beams"
REJECT_GEOMETRY = "invalid scan geometry"
REJECT_CORRUPT = "corrupt message"


def _stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


@dataclass(frozen=True)
class OdometrySeries:
    """nav_msgs/Odometry as arrays, sorted by time, one sample per distinct stamp.

    t_ns: (N,) int64 ns (replay clock); x, y: m; yaw: rad in (-pi, pi]; v: m/s (twist
    linear.x); w: rad/s (twist angular.z). Pose in ``frame_id``, twist in ``child_frame_id``.
    """

    t_ns: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray
    w: np.ndarray
    frame_id: str = ""
    child_frame_id: str = ""

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def at(self, t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Interpolate to query times.

        Returns pose (M, 3) [x, y, yaw], twist (M, 2) [v, w], and where (M,) int8:
        -1 before the first sample, 0 covered, +1 after the last sample (pose and twist
        hold the nearest end sample there; the replay skips those scans).
        """
        t_q = np.asarray(t_ns, dtype=np.int64)
        i, j, frac = _bracket(self.t_ns, t_q)
        cols = [_lerp(a, i, j, frac) for a in (self.x, self.y)]
        yaw = wrap_angles(self.yaw[i] + frac * wrap_angles(self.yaw[j] - self.yaw[i]))
        twist = [_lerp(a, i, j, frac) for a in (self.v, self.w)]
        where = np.where(t_q < self.t_ns[0], -1, np.where(t_q > self.t_ns[-1], 1, 0))
        return np.column_stack((*cols, yaw)), np.column_stack(twist), where.astype(np.int8)


@dataclass(frozen=True)
class ImuSeries:
    """Gyro yaw rate: t_ns (N,) int64 ns, w_z (N,) rad/s about the base z axis."""

    t_ns: np.ndarray
    w_z: np.ndarray
    frame_id: str = ""

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def at(self, t_ns: np.ndarray) -> np.ndarray:
        """(M,) rad/s interpolated to query times; NaN outside the recorded span."""
        t_q = np.asarray(t_ns, dtype=np.int64)
        i, j, frac = _bracket(self.t_ns, t_q)
        out = _lerp(self.w_z, i, j, frac)
        return np.where((t_q < self.t_ns[0]) | (t_q > self.t_ns[-1]), np.nan, out)


@dataclass(frozen=True)
class TimedValues:
    """Headerless samples: t_ns (N,) int64 ns, values (N, k) float64."""

    t_ns: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return int(self.t_ns.size)

    def nearest(self, t_ns: np.ndarray, max_gap_ns: int) -> np.ndarray:
        """(M, k): the sample nearest in time to each query, NaN if none within max_gap_ns."""
        t_q = np.asarray(t_ns, dtype=np.int64)
        k = self.values.shape[1]
        if len(self) == 0:
            return np.full((t_q.size, k), np.nan)
        hi = np.clip(np.searchsorted(self.t_ns, t_q), 0, len(self) - 1)
        lo = np.clip(hi - 1, 0, len(self) - 1)
        pick = np.where(np.abs(self.t_ns[lo] - t_q) <= np.abs(self.t_ns[hi] - t_q), lo, hi)
        out = self.values[pick].astype(np.float64)
        out[np.abs(self.t_ns[pick] - t_q) > max_gap_ns] = np.nan
        return out


@dataclass(frozen=True)
class Goal:
    """A goal pose from geometry_msgs/PoseStamped: (x, y) m and yaw rad in frame_id."""

    t_ns: int
    x: float
    y: float
    yaw: float
    frame_id: str


@dataclass
class BagData:
    """Everything the replay and the scan comparison need from one bag."""

    path: Path
    topics: TopicResolution
    clock: str
    """'header' or 'receive' (see the module docstring)."""
    scans: list[LaserScan]
    """Convertible scans in replay-clock order; ``stamp_ns`` is the header stamp as recorded."""
    scan_times_ns: np.ndarray
    """(S,) int64, replay-clock time of each entry of ``scans``."""
    scan_frame_id: str
    scan_rejects: list[tuple[int, str]]
    """(time ns, reason) of scan messages that could not become a LaserScan."""
    scan_messages: int
    """All messages on the scan topic, including rejected and corrupt ones."""
    mount: Pose2D
    mount_source: str
    odometry: OdometrySeries | None
    """Pose source: the odometry topic, else the wheel odometry (see notes)."""
    wheel_odometry: OdometrySeries | None
    imu: ImuSeries | None
    cmd_vel: TimedValues | None
    """(N, 2) [v m/s, w rad/s]."""
    planner_params: TimedValues | None
    """(N, 5) [wp, wc, ws, tau, action_index]."""
    goals: list[Goal]
    tf: TransformTree
    corrupt: dict[str, int] = field(default_factory=dict)
    """Topic -> messages that failed to deserialise (skipped)."""
    notes: list[str] = field(default_factory=list)


def _bracket(t_src: np.ndarray, t_q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices i <= j around each query and the fraction in [0, 1] between them."""
    n = t_src.size
    i = np.clip(np.searchsorted(t_src, t_q, side="right") - 1, 0, n - 1)
    j = np.minimum(i + 1, n - 1)
    span = (t_src[j] - t_src[i]).astype(np.float64)
    offset = (t_q - t_src[i]).astype(np.float64)
    frac = np.divide(offset, span, out=np.zeros_like(span), where=span > 0)
    return i, j, np.clip(frac, 0.0, 1.0)


def _lerp(a: np.ndarray, i: np.ndarray, j: np.ndarray, frac: np.ndarray) -> np.ndarray:
    # a[i] + 0 * (...) keeps knot values bit-exact.
    return a[i] + frac * (a[j] - a[i])


def _usable_stamps(stamps: np.ndarray) -> str | None:
    """Why header stamps cannot drive the replay, or None if they can."""
    if stamps.size == 0:
        return None
    if (stamps <= 0).any():
        return f"{int((stamps <= 0).sum())} zero stamps"
    if (np.diff(stamps) < 0).any():
        return f"stamps go backwards {int((np.diff(stamps) < 0).sum())} times"
    return None


def _open(path: Path) -> Any:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    # Bags recorded by ROS 2 Humble's sqlite3 plugin carry no message definitions.
    store = Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.ROS2_HUMBLE
    try:
        reader = AnyReader([path], default_typestore=get_typestore(store))
        reader.open()
    except Exception as err:
        raise BagFormatError(f"{path}: cannot open bag: {err}") from err
    return reader


def _extract(role: str, msg: Any) -> Any:
    """The fields a role needs, as plain Python/numpy values (raises on malformed data)."""
    if role == "scan":
        return (
            _stamp_ns(msg.header),
            msg.header.frame_id,
            float(msg.angle_min),
            float(msg.angle_increment),
            np.asarray(msg.ranges, dtype=np.float64).copy(),
            float(msg.range_min),
            float(msg.range_max),
        )
    if role in ("odometry", "wheel_odometry"):
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        t = msg.twist.twist
        values = (
            float(p.x),
            float(p.y),
            yaw_from_quaternion(q.x, q.y, q.z, q.w),
            float(t.linear.x),
            float(t.angular.z),
        )
        if not all(math.isfinite(v) for v in values):  # would poison the interpolation
            raise ValueError(f"non-finite pose or twist {values}")
        return (_stamp_ns(msg.header), msg.header.frame_id, msg.child_frame_id, *values)
    if role == "imu":
        av = msg.angular_velocity
        if not math.isfinite(av.z):
            raise ValueError(f"non-finite angular_velocity.z {av.z}")
        return (_stamp_ns(msg.header), msg.header.frame_id, float(av.x), float(av.y), float(av.z))
    if role in ("tf", "tf_static"):
        out = []
        for ts in msg.transforms:
            tr, rot = ts.transform.translation, ts.transform.rotation
            mat = matrix_from_transform((tr.x, tr.y, tr.z), (rot.x, rot.y, rot.z, rot.w))
            out.append((_stamp_ns(ts.header), ts.header.frame_id, ts.child_frame_id, mat))
        return out
    if role == "goal":
        p, q = msg.pose.position, msg.pose.orientation
        yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w)
        return (_stamp_ns(msg.header), msg.header.frame_id, float(p.x), float(p.y), yaw)
    if role == "cmd_vel":
        return (float(msg.linear.x), float(msg.angular.z))
    if role == "planner_params":
        data = np.asarray(msg.data, dtype=np.float64)
        if data.size != 5:
            raise ValueError(f"expected 5 values [wp, wc, ws, tau, action_index], got {data.size}")
        return data.copy()
    raise KeyError(role)


def _odometry_series(samples: list[tuple[int, Any]], clock: str) -> OdometrySeries | None:
    if not samples:
        return None
    t = np.array([s[1][0] if clock == "header" else s[0] for s in samples], dtype=np.int64)
    vals = np.array([s[1][3:] for s in samples], dtype=np.float64).reshape(-1, 5)
    order = np.argsort(t, kind="stable")
    t, vals = t[order], vals[order]
    keep = np.concatenate(([True], np.diff(t) > 0))
    t, vals = t[keep], vals[keep]
    first = samples[0][1]
    return OdometrySeries(
        t, *vals.T, frame_id=first[1].lstrip("/"), child_frame_id=first[2].lstrip("/")
    )


def read_bag(
    path: str | Path,
    *,
    topics: TopicMap | None = None,
    mount: Pose2D | None = None,
    clock: Clock = "auto",
) -> BagData:
    """Read a bag's scans, odometry, IMU, tf, goals, commands and planner parameters.

    path: ROS 1 ``.bag``, ROS 2 bag directory, or a bare ``.db3`` / ``.mcap`` file.
    topics: role -> topic; absent defaults fall back by message type (see ``resolve_topics``).
    mount: the lidar's pose in base_link; overrides the bag's tf.
    clock: which timestamps drive the replay (module docstring); "auto" decides per bag.

    Raises ``BagFormatError`` (naming the bag and topic) for a missing or unreadable bag,
    no usable LaserScan topic, or a scan topic whose every message is corrupt. Single
    corrupt messages (undecodable, or odometry / gyro rate holding NaN or inf) are counted
    in ``BagData.corrupt`` and skipped. A bag whose storage breaks off mid-way is read up to
    the break (with a note).
    """
    path = Path(path)
    if not path.exists():
        raise BagFormatError(f"{path}: no such bag (file or directory)")
    reader = _open(path)
    try:
        available = {name: info.msgtype for name, info in reader.topics.items()}
        resolution = resolve_topics(available, topics, bag=str(path))
        if resolution["scan"] is None:
            listing = ", ".join(f"{t} [{ty}]" for t, ty in sorted(available.items())) or "none"
            raise BagFormatError(
                f"{path}: no usable {LASER_SCAN} topic ({'; '.join(resolution.notes[:1])}); "
                f"topics in bag: {listing}"
            )
        roles_of: dict[str, list[str]] = {}
        for role, topic in resolution.topics.items():
            if topic is not None:
                roles_of.setdefault(topic, []).append(role)
        connections = [c for c in reader.connections if c.topic in roles_of]
        raw: dict[str, list[tuple[int, Any]]] = {role: [] for role in resolution.topics}
        corrupt: dict[str, int] = {}
        corrupt_scan_times: list[int] = []
        stopped: str | None = None
        messages = reader.messages(connections=connections)
        while True:
            try:
                conn, receive_ns, data = next(messages)
            except StopIteration:
                break
            except Exception as err:  # noqa: BLE001 - damaged storage: keep what was read
                read = sum(len(v) for v in raw.values())
                if not read:
                    raise BagFormatError(f"{path}: cannot read messages: {err}") from err
                stopped = f"reading stopped after {read} messages: {type(err).__name__}: {err}"
                break
            try:
                msg = reader.deserialize(data, conn.msgtype)
                records = [(role, _extract(role, msg)) for role in roles_of[conn.topic]]
            except Exception:  # noqa: BLE001 - any decoding failure is one corrupt message
                corrupt[conn.topic] = corrupt.get(conn.topic, 0) + 1
                if "scan" in roles_of[conn.topic]:
                    corrupt_scan_times.append(int(receive_ns))
                continue
            for role, rec in records:
                raw[role].append((int(receive_ns), rec))
    finally:
        with suppress(Exception):
            reader.close()
    data = _assemble(path, resolution, raw, corrupt, corrupt_scan_times, mount, clock)
    if stopped is not None:
        data.notes.append(f"{path}: {stopped}; replaying the messages before it")
    return data


def _assemble(
    path: Path,
    resolution: TopicResolution,
    raw: dict[str, list[tuple[int, Any]]],
    corrupt: dict[str, int],
    corrupt_scan_times: list[int],
    mount: Pose2D | None,
    clock: Clock,
) -> BagData:
    notes = list(resolution.notes)
    scan_topic = resolution["scan"]
    if not raw["scan"]:
        what = (
            f"all {corrupt.get(scan_topic, 0)} messages are corrupt" if corrupt else "it is empty"
        )
        raise BagFormatError(f"{path}: scan topic {scan_topic!r} has no readable message ({what})")
    for topic, n in corrupt.items():
        notes.append(f"{topic}: {n} corrupt message(s) skipped")

    pose_role = "odometry"
    if not raw["odometry"] and raw["wheel_odometry"]:
        pose_role = "wheel_odometry"
        notes.append(
            f"odometry: no fused odometry; pose source is wheel odometry {resolution['wheel_odometry']!r}"
        )

    # The clock: header stamps unless a stream that gets aligned cannot support them.
    problems = []
    for role in ("scan", pose_role, "imu"):
        why = _usable_stamps(np.array([rec[0] for _, rec in raw[role]], dtype=np.int64))
        if why:
            problems.append(f"{resolution[role]}: {why}")
    if clock == "auto":
        clock = "receive" if problems else "header"
        notes.append(
            "clock: bag receive time (header stamps unusable: " + "; ".join(problems) + ")"
            if problems
            else "clock: header stamps"
        )
    elif clock == "header":
        if problems:
            raise BagFormatError(f"{path}: clock='header' requested but " + "; ".join(problems))
        notes.append("clock: header stamps (requested)")
    elif clock == "receive":
        notes.append("clock: bag receive time (requested)")
    else:
        raise BagFormatError(f"{path}: unknown clock {clock!r}; use 'auto', 'header' or 'receive'")

    def when(receive_ns: int, stamp_ns: int) -> int:
        return stamp_ns if clock == "header" else receive_ns

    scan_raw = raw["scan"]
    offset_ns = 0
    if clock == "header":
        offset_ns = int(np.median([rec[0] - r for r, rec in scan_raw]))

    # tf tree: static edges, then dynamic ones on the replay clock.
    tree = TransformTree()
    for _, recs in raw["tf_static"]:
        for _stamp, parent, child, mat in recs:
            tree.add(parent, child, mat)
    for receive_ns, recs in raw["tf"]:
        for stamp, parent, child, mat in recs:
            tree.add(parent, child, mat, when(receive_ns, stamp))

    frames = {rec[1].lstrip("/") for _, rec in scan_raw}
    scan_frame = scan_raw[0][1][1].lstrip("/")
    if len(frames) > 1:
        notes.append(f"scan: several frame_ids {sorted(frames)}; mount taken for {scan_frame!r}")
    flipped = False
    if mount is not None:
        mount_source = "argument"
    else:
        mount, flipped, mount_source = _find_mount(tree, scan_frame)
        if mount_source.startswith("default"):
            notes.append(f"mount: {mount_source}")

    scans: list[LaserScan] = []
    scan_times: list[int] = []
    rejects = [(t + offset_ns, REJECT_CORRUPT) for t in corrupt_scan_times]
    for receive_ns, (stamp, _frame, a0, inc, ranges, rmin, rmax) in scan_raw:
        t = when(receive_ns, stamp)
        if ranges.size == 0:
            rejects.append((t, REJECT_ZERO_BEAMS))
            continue
        if flipped:
            a0, inc = -a0, -inc
        try:
            scans.append(LaserScan(a0, inc, ranges, rmin, rmax, stamp_ns=stamp))
        except ScanError as err:
            if not any(r == REJECT_GEOMETRY for _, r in rejects):
                notes.append(f"{scan_topic}: scan at {t} ns rejected: {err}")
            rejects.append((t, REJECT_GEOMETRY))
            continue
        scan_times.append(t)
    scan_order = np.argsort(np.array(scan_times, dtype=np.int64), kind="stable")
    scans = [scans[k] for k in scan_order]

    odometry = _odometry_series(raw[pose_role], clock)
    wheel = _odometry_series(raw["wheel_odometry"], clock)
    imu = _imu_series(raw["imu"], clock, tree, notes)

    def headerless(role: str, width: int) -> TimedValues | None:
        if not raw[role]:
            return None
        t = np.array([r + offset_ns for r, _ in raw[role]], dtype=np.int64)
        vals = np.array([rec for _, rec in raw[role]], dtype=np.float64).reshape(-1, width)
        order = np.argsort(t, kind="stable")
        return TimedValues(t[order], vals[order])

    if clock == "header" and (raw["cmd_vel"] or raw["planner_params"]) and offset_ns:
        notes.append(
            f"headerless topics shifted by {offset_ns / 1e9:+.6f} s "
            "(median scan header stamp - receive time) onto the header clock"
        )
    goals = [
        Goal(when(r, rec[0]), rec[2], rec[3], rec[4], rec[1].lstrip("/")) for r, rec in raw["goal"]
    ]
    return BagData(
        path=path,
        topics=resolution,
        clock=clock,
        scans=scans,
        scan_times_ns=np.array(scan_times, dtype=np.int64)[scan_order],
        scan_frame_id=scan_frame,
        scan_rejects=rejects,
        scan_messages=len(scan_raw) + len(corrupt_scan_times),
        mount=mount,
        mount_source=mount_source,
        odometry=odometry,
        wheel_odometry=wheel,
        imu=imu,
        cmd_vel=headerless("cmd_vel", 2),
        planner_params=headerless("planner_params", 5),
        goals=goals,
        tf=tree,
        corrupt=corrupt,
        notes=notes,
    )


def _find_mount(tree: TransformTree, scan_frame: str) -> tuple[Pose2D, bool, str]:
    """The lidar frame's pose in the body frame: (pose, upside down, how it was found)."""
    if scan_frame in BASE_FRAMES:
        return Pose2D(), False, f"scan frame is {scan_frame!r}"
    for base in BASE_FRAMES:
        mat = tree.lookup(base, scan_frame)
        if mat is not None:
            pose, flipped = pose2d_from_matrix(mat)
            chain = " -> ".join(tree.path(base, scan_frame) or [])
            kind = (
                "static"
                if all(k in tree.static for k in _chain_keys(tree, base, scan_frame))
                else "tf"
            )
            extra = ", lidar upside down: scan angles mirrored" if flipped else ""
            return pose, flipped, f"{kind} transform {chain}{extra}"
    k = KACHAKA_LIDAR_MOUNT
    return (
        k,
        False,
        f"default Kachaka lidar mount ({k.x}, {k.y}, yaw {k.yaw}): no transform from "
        f"{' or '.join(BASE_FRAMES)} to scan frame {scan_frame!r} in the bag's tf",
    )


def _chain_keys(tree: TransformTree, target: str, source: str) -> list[tuple[str, str]]:
    chain = tree.path(target, source) or []
    keys = []
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        keys.append((a, b) if (a, b) in tree.static or (a, b) in tree.dynamic else (b, a))
    return keys


def _imu_series(
    samples: list[tuple[int, Any]], clock: str, tree: TransformTree, notes: list[str]
) -> ImuSeries | None:
    if not samples:
        return None
    t = np.array([s[1][0] if clock == "header" else s[0] for s in samples], dtype=np.int64)
    omega = np.array([s[1][2:] for s in samples], dtype=np.float64).reshape(-1, 3)
    frame = samples[0][1][1].lstrip("/")
    w_z = omega[:, 2]
    if frame and frame not in BASE_FRAMES:
        mat = next((m for b in BASE_FRAMES if (m := tree.lookup(b, frame)) is not None), None)
        if mat is None:
            notes.append(f"imu: no transform to frame {frame!r}; its z axis taken as the body's")
        elif not np.allclose(mat[2, :3], (0.0, 0.0, 1.0)):
            w_z = omega @ mat[2, :3]  # body z component of the rotated rate vector
    order = np.argsort(t, kind="stable")
    return ImuSeries(t[order], w_z[order], frame)


def first_goal(bag: BagData) -> tuple[np.ndarray, str]:
    """The bag's first goal in the odometry frame: ((2,) m, where it came from).

    A goal in another frame (e.g. ``map``) is moved into the odometry frame with the bag's
    tf at the goal's time. Raises ``BagFormatError`` if there is no goal or no transform.
    """
    topic = bag.topics["goal"]
    if not bag.goals:
        raise BagFormatError(
            f"{bag.path}: no goal: the bag has no PoseStamped goal "
            f"(topic {topic or TopicMap().goal!r}); pass one in the odometry frame, e.g. --goal X,Y"
        )
    g = bag.goals[0]
    source = f"first message on {topic}"
    if len(bag.goals) > 1:
        source += f" ({len(bag.goals)} goals in bag; later ones ignored)"
    odom = bag.odometry.frame_id if bag.odometry is not None else ""
    if not g.frame_id or not odom or g.frame_id == odom:
        return np.array([g.x, g.y]), source
    mat = bag.tf.lookup(odom, g.frame_id, g.t_ns)
    if mat is None:
        raise BagFormatError(
            f"{bag.path}: goal on {topic} is in frame {g.frame_id!r} but odometry is in {odom!r} "
            "and the bag's tf does not connect them; pass the goal in the odometry frame"
        )
    p = mat @ np.array([g.x, g.y, 0.0, 1.0])
    return p[:2].copy(), f"{source}, transformed {g.frame_id} -> {odom}"
