"""Topic names of the Kachaka ROS 2 bridge, and how a bag's topics are matched to them.

Every role (scan, odometry, ...) has a default topic and a message type. A role whose
topic is absent from a bag falls back to the bag's only unclaimed topic of that type, and
the fallback is reported in ``TopicResolution.notes`` so it shows up in every output.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields

from d3dwa_bullet.errors import BagFormatError

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
IMU = "sensor_msgs/msg/Imu"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TWIST = "geometry_msgs/msg/Twist"
FLOAT64_ARRAY = "std_msgs/msg/Float64MultiArray"

#: Layout of the planner-parameter message (our own topic, std_msgs/Float64MultiArray).
PLANNER_PARAMS_LAYOUT = ("wp", "wc", "ws", "tau", "action_index")


@dataclass(frozen=True)
class TopicMap:
    """Topic name per role. ``None`` disables a role (it is neither read nor auto-selected)."""

    scan: str | None = "/kachaka/lidar/scan"
    """sensor_msgs/msg/LaserScan from the 2D lidar."""
    odometry: str | None = "/kachaka/odometry/odometry"
    """nav_msgs/msg/Odometry, the robot's fused odometry: the replay's pose source."""
    wheel_odometry: str | None = "/kachaka/wheel_odometry/wheel_odometry"
    """nav_msgs/msg/Odometry from the wheel encoders only."""
    imu: str | None = "/kachaka/imu/imu"
    """sensor_msgs/msg/Imu; only angular_velocity is used."""
    tf: str | None = "/tf"
    """tf2_msgs/msg/TFMessage, dynamic transforms."""
    tf_static: str | None = "/tf_static"
    """tf2_msgs/msg/TFMessage, static transforms (lidar mount)."""
    goal: str | None = "/goal_pose"
    """geometry_msgs/msg/PoseStamped navigation goal."""
    cmd_vel: str | None = "/kachaka/manual_control/cmd_vel"
    """geometry_msgs/msg/Twist commanded velocity."""
    planner_params: str | None = "/d3dwa/planner_params"
    """std_msgs/msg/Float64MultiArray [wp, wc, ws, tau, action_index] chosen per step."""

    def roles(self) -> tuple[str, ...]:
        return tuple(f.name for f in fields(self))


#: Message type of each role.
ROLE_TYPES: dict[str, str] = {
    "scan": LASER_SCAN,
    "odometry": ODOMETRY,
    "wheel_odometry": ODOMETRY,
    "imu": IMU,
    "tf": TF_MESSAGE,
    "tf_static": TF_MESSAGE,
    "goal": POSE_STAMPED,
    "cmd_vel": TWIST,
    "planner_params": FLOAT64_ARRAY,
}

_DEFAULTS = TopicMap()


@dataclass
class TopicResolution:
    """Which bag topic serves each role, and how it was chosen."""

    topics: dict[str, str | None]
    """Role -> topic in the bag (None: the role has no topic)."""
    notes: list[str] = field(default_factory=list)
    """One line per role that did not resolve to its configured topic."""

    def __getitem__(self, role: str) -> str | None:
        return self.topics[role]


def _basename(topic: str) -> str:
    return topic.rstrip("/").rsplit("/", 1)[-1]


def resolve_topics(
    available: Mapping[str, str | None], topics: TopicMap | None = None, bag: str = "bag"
) -> TopicResolution:
    """Match roles to the topics of a bag.

    available: topic -> message type as stored in the bag.
    A configured topic that is present with the right type is used as is. A default topic
    that is absent (or has another type) falls back to the only unclaimed topic of the role's
    type; among several, to the only one with the default's last name component (``.../imu``).
    A topic the caller set explicitly must be present with the right type, else
    ``BagFormatError``: an explicit choice is never silently replaced.
    """
    topics = topics or TopicMap()
    chosen: dict[str, str | None] = {}
    notes: list[str] = []
    pending: list[str] = []
    for role in topics.roles():
        name = getattr(topics, role)
        want = ROLE_TYPES[role]
        explicit = name != getattr(_DEFAULTS, role)
        if name is None:
            chosen[role] = None
            continue
        have = available.get(name)
        if name in available and have == want:
            chosen[role] = name
            continue
        if explicit:
            what = "is absent" if name not in available else f"has type {have}"
            same = sorted(t for t, ty in available.items() if ty == want)
            raise BagFormatError(
                f"{bag}: topic {name!r} requested for {role} {what}; expected {want} "
                f"(topics of that type: {same or 'none'})"
            )
        if name in available:
            notes.append(f"{role}: default topic {name!r} has type {have}, expected {want}")
        pending.append(role)

    claimed = {t for t in chosen.values() if t is not None}
    for role in pending:
        name = getattr(topics, role)
        want = ROLE_TYPES[role]
        candidates = sorted(t for t, ty in available.items() if ty == want and t not in claimed)
        if len(candidates) > 1:
            by_name = [t for t in candidates if _basename(t) == _basename(name)]
            if len(by_name) == 1:
                chosen[role] = by_name[0]
                claimed.add(by_name[0])
                notes.append(
                    f"{role}: {name!r} absent; using {by_name[0]!r} "
                    f"(the only {want} topic named '{_basename(name)}' among {candidates})"
                )
                continue
            chosen[role] = None
            notes.append(
                f"{role}: {name!r} absent and {len(candidates)} {want} topics are ambiguous "
                f"{candidates}; choose one explicitly"
            )
        elif candidates:
            chosen[role] = candidates[0]
            claimed.add(candidates[0])
            notes.append(
                f"{role}: {name!r} absent; using {candidates[0]!r} (the only {want} topic)"
            )
        else:
            chosen[role] = None
            notes.append(f"{role}: {name!r} absent and no other {want} topic; role unused")
    return TopicResolution(topics={r: chosen[r] for r in topics.roles()}, notes=notes)
