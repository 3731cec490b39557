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

Alignment of odometry, IMU and commands to scan times: ``transfer.time_series``.
"""

from __future__ import annotations

from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from d3dwa_bullet.errors import BagFormatError, ScanError
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from transfer.bag_files import check_bag_files
from transfer.decode import decode_fields
from transfer.mounts import body_yaw_rate, find_lidar_mount
from transfer.time_series import Goal, ImuSeries, OdometrySeries, TimedValues
from transfer.topics import LASER_SCAN, TopicMap, TopicResolution, resolve_topics
from transfer.transforms import TransformTree

Clock = Literal["auto", "header", "receive"]

REJECT_ZERO_BEAMS = "zero beams"
REJECT_GEOMETRY = "invalid scan geometry"
REJECT_CORRUPT = "corrupt message"


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
    # rosbags takes ~0.1 s to import; every `d3dwa` command imports transfer, few open a bag.
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
    check_bag_files(path)  # no endless metadata.yaml, no FIFO to block on
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
                records = [(role, decode_fields(role, msg)) for role in roles_of[conn.topic]]
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
        mount, flipped, mount_source = find_lidar_mount(tree, scan_frame)
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


def _imu_series(
    samples: list[tuple[int, Any]], clock: str, tree: TransformTree, notes: list[str]
) -> ImuSeries | None:
    if not samples:
        return None
    t = np.array([s[1][0] if clock == "header" else s[0] for s in samples], dtype=np.int64)
    omega = np.array([s[1][2:] for s in samples], dtype=np.float64).reshape(-1, 3)
    frame = samples[0][1][1].lstrip("/")
    w_z, note = body_yaw_rate(omega, frame, tree)
    if note is not None:
        notes.append(note)
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
