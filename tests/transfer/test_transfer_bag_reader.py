"""Reading bags back: values, stamps, topics, clock, interpolation, tf mount, errors."""

import math
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from tests.support.bag_messages import scan_msg
from transfer.bag_reader import OdometrySeries, first_goal, read_bag
from transfer.bag_writer import BagRecorder, Frames
from transfer.synthetic import write_corridor_bag
from transfer.topics import LASER_SCAN, POSE_STAMPED, TF_MESSAGE, TopicMap
from transfer.transforms import quaternion_from_yaw, yaw_from_quaternion

MS = 1_000_000


def tf_msg(rec, parent, child, xyz, quat):
    x, y, z, w = quat
    tf = rec.message(
        "geometry_msgs/msg/Transform",
        translation=rec.message("geometry_msgs/msg/Vector3", x=xyz[0], y=xyz[1], z=xyz[2]),
        rotation=rec.message("geometry_msgs/msg/Quaternion", x=x, y=y, z=z, w=w),
    )
    stamped = rec.message(
        "geometry_msgs/msg/TransformStamped",
        header=rec.header(MS, parent),
        child_frame_id=child,
        transform=tf,
    )
    return rec.message(TF_MESSAGE, transforms=[stamped])


@pytest.mark.parametrize(
    ("storage", "name"), [("sqlite3", "bag2"), ("mcap", "bag_mcap"), ("ros1", "bag1.bag")]
)
def test_round_trip_reproduces_scans_odometry_and_params(tmp_path, storage, name):
    path = tmp_path / name
    steps = write_corridor_bag(
        path,
        storage=storage,
        n_scans=12,
        noise_std=0.01,
        dropout={"nan": 0.05, "pos_inf": 0.05, "neg_inf": 0.02, "zero": 0.02},
    )
    bag = read_bag(path)
    assert bag.clock == "header"
    assert bag.topics.notes == []
    assert bag.scan_messages == len(bag.scans) == 12
    assert bag.mount == Pose2D(0.156, 0.0, 0.0)
    assert "static transform base_link -> lidar_link" in bag.mount_source
    for (t, sent, _), got, t_replay in zip(steps, bag.scans, bag.scan_times_ns, strict=True):
        assert got.stamp_ns == t == t_replay
        np.testing.assert_array_equal(got.ranges, sent.ranges)  # NaN == NaN here
        assert (got.angle_min, got.angle_increment) == (sent.angle_min, sent.angle_increment)
        assert (got.range_min, got.range_max) == (sent.range_min, sent.range_max)
    odom = bag.odometry
    np.testing.assert_array_equal(odom.t_ns, [s[0] for s in steps])
    np.testing.assert_array_equal(odom.x, [s[2][0] for s in steps])
    assert odom.frame_id == "odom" and odom.child_frame_id == "base_link"
    np.testing.assert_array_equal(bag.planner_params.values[0], [1.0, 2.0, 1.0, 4.0, 30.0])
    np.testing.assert_array_equal(bag.imu.w_z, 0.0)
    assert first_goal(bag)[0].tolist() == [5.0, 0.0]


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_bare_storage_file_is_readable(tmp_path, storage):
    write_corridor_bag(tmp_path / "run", storage=storage, n_scans=3)
    (file,) = [p for p in (tmp_path / "run").iterdir() if p.suffix in (".db3", ".mcap")]
    assert len(read_bag(file).scans) == 3


TINY_YAW = 2.0 * sys.float_info.min
"""Below this |yaw|, sin(yaw / 2) is subnormal and has too few bits to carry yaw exactly."""


@given(
    st.floats(
        min_value=-math.pi, max_value=math.pi, exclude_min=True, allow_subnormal=False
    ).filter(lambda yaw: yaw == 0.0 or abs(yaw) >= TINY_YAW)
)
def test_yaw_survives_the_quaternion_exactly(yaw):
    assert yaw_from_quaternion(*quaternion_from_yaw(yaw)) == yaw


@pytest.mark.parametrize("yaw", [4.202392461604117e-308, -3e-308, sys.float_info.min])
def test_a_yaw_below_two_smallest_normals_comes_back_within_one_subnormal_step(yaw):
    assert abs(yaw_from_quaternion(*quaternion_from_yaw(yaw)) - yaw) <= 5e-324


def test_float64_values_round_trip_exactly(tmp_path):
    rng = np.random.default_rng(3)
    poses = np.column_stack((rng.normal(size=(30, 2)) * 10, rng.uniform(-np.pi, np.pi, 30)))
    twists = rng.normal(size=(30, 2))
    scan = LaserScan(-1.0, 0.01, np.full(200, 1.0), 0.05, 10.0)
    with BagRecorder(tmp_path / "b") as rec:
        for k in range(30):
            rec.write_step(
                (k + 1) * 100 * MS,
                scan,
                poses[k],
                twists[k],
                gyro_w=twists[k, 1],
                params=rng.normal(size=5),
            )
    bag = read_bag(tmp_path / "b")
    o = bag.odometry
    np.testing.assert_array_equal(np.column_stack((o.x, o.y, o.yaw)), poses)
    np.testing.assert_array_equal(np.column_stack((o.v, o.w)), twists)
    np.testing.assert_array_equal(bag.imu.w_z, twists[:, 1])


def test_odometry_is_interpolated_to_scan_times_with_unwrapped_yaw():
    odom = OdometrySeries(
        t_ns=np.array([0, 100, 200]) * MS,
        x=np.array([0.0, 1.0, 3.0]),
        y=np.zeros(3),
        yaw=np.array([3.0, -3.0, -2.0]),  # crosses +pi -> -pi between the first two samples
        v=np.array([1.0, 2.0, 3.0]),
        w=np.zeros(3),
    )
    pose, twist, where = odom.at(np.array([-10, 0, 50, 100, 150, 200, 201]) * MS)
    assert where.tolist() == [-1, 0, 0, 0, 0, 0, 1]
    np.testing.assert_allclose(pose[1:6, 0], [0.0, 0.5, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(twist[1:6, 0], [1.0, 1.5, 2.0, 2.5, 3.0])
    mid = pose[2, 2]
    assert abs(abs(mid) - math.pi) < 1e-12  # halfway between 3.0 and -3.0 the short way is pi
    assert pose[4, 2] == pytest.approx(-2.5)
    assert pose[3, 2] == -3.0 and pose[1, 2] == 3.0  # knots exactly


def test_interpolation_in_a_bag_with_offset_scans(tmp_path):
    scan = LaserScan(-1.0, 0.1, np.full(21, 2.0), 0.05, 10.0)
    with BagRecorder(tmp_path / "b") as rec:
        for k in range(5):
            rec.write_odometry(k * 100 * MS, (0.1 * k, 0.0, 0.0), (1.0, 0.0))
        for k in range(4):
            t = (k * 100 + 50) * MS
            rec.write_scan(t, LaserScan(-1.0, 0.1, scan.ranges, 0.05, 10.0, stamp_ns=t))
    bag = read_bag(tmp_path / "b")
    pose, _, where = bag.odometry.at(bag.scan_times_ns)
    np.testing.assert_allclose(pose[:, 0], [0.05, 0.15, 0.25, 0.35])
    assert (where == 0).all()


def test_topics_selected_by_type_when_defaults_absent(tmp_path):
    topics = TopicMap(scan="/scan", odometry="/odom", imu="/imu/data", wheel_odometry=None)
    write_corridor_bag(tmp_path / "b", topics=topics, n_scans=3)
    bag = read_bag(tmp_path / "b")
    assert bag.topics["scan"] == "/scan"
    assert bag.topics["odometry"] == "/odom"
    assert bag.topics["imu"] == "/imu/data"
    assert any(n.startswith("scan: '/kachaka/lidar/scan' absent; using '/scan'") for n in bag.notes)
    assert len(bag.scans) == 3 and len(bag.odometry) == 3


def test_ambiguous_scan_topics_are_an_error(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        rec.write_message("/front", LASER_SCAN, MS, scan_msg(rec, MS, [1.0, 2.0]))
        rec.write_message("/rear", LASER_SCAN, MS, scan_msg(rec, MS, [1.0, 2.0]))
    with pytest.raises(BagFormatError, match=r"no usable sensor_msgs/msg/LaserScan.*ambiguous"):
        read_bag(tmp_path / "b")
    assert len(read_bag(tmp_path / "b", topics=TopicMap(scan="/rear")).scans) == 1


def test_zero_header_stamps_switch_to_receive_time(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        for k in range(1, 4):
            rec.write_message(
                LASER_SCAN_TOPIC, LASER_SCAN, k * 100 * MS, scan_msg(rec, 0, [1.0] * 5)
            )
            rec.write_odometry(k * 100 * MS, (k, 0.0, 0.0), (0.0, 0.0))
    bag = read_bag(tmp_path / "b")
    assert bag.clock == "receive"
    assert any("receive time" in n and "zero stamps" in n for n in bag.notes)
    np.testing.assert_array_equal(bag.scan_times_ns, [100 * MS, 200 * MS, 300 * MS])
    assert [s.stamp_ns for s in bag.scans] == [0, 0, 0]
    with pytest.raises(BagFormatError, match="clock='header' requested"):
        read_bag(tmp_path / "b", clock="header")


def test_backwards_header_stamps_switch_to_receive_time(tmp_path):
    stamps = [300, 100, 200]
    with BagRecorder(tmp_path / "b") as rec:
        for k, s in enumerate(stamps, start=1):
            rec.write_message(
                LASER_SCAN_TOPIC, LASER_SCAN, k * 100 * MS, scan_msg(rec, s * MS, [1.0] * 5)
            )
    bag = read_bag(tmp_path / "b")
    assert bag.clock == "receive"
    assert any("backwards" in n for n in bag.notes)


def test_headerless_topics_are_shifted_onto_the_header_clock(tmp_path):
    shift = 5_000 * MS  # header stamps run 5 s behind the receive clock (e.g. sim time)
    with BagRecorder(tmp_path / "b") as rec:
        for k in range(1, 6):
            t = shift + k * 100 * MS
            rec.write_scan(t, LaserScan(-1.0, 0.5, np.ones(5), 0.05, 10.0, stamp_ns=k * 100 * MS))
            rec.write_odometry(t, (0.0, 0.0, 0.0), (0.0, 0.0), stamp_ns=k * 100 * MS)
            rec.write_cmd(t, (0.01 * k, 0.0))
    bag = read_bag(tmp_path / "b")
    assert bag.clock == "header"
    np.testing.assert_array_equal(bag.cmd_vel.t_ns, bag.scan_times_ns)
    cmds = bag.cmd_vel.nearest(bag.scan_times_ns, 10 * MS)
    np.testing.assert_allclose(cmds[:, 0], [0.01, 0.02, 0.03, 0.04, 0.05])
    assert any("shifted by -5.000000 s" in n for n in bag.notes)


LASER_SCAN_TOPIC = TopicMap().scan


def test_mount_composed_through_a_tf_chain(tmp_path):
    q = quaternion_from_yaw(math.pi / 2)
    with BagRecorder(tmp_path / "b", topics=TopicMap(tf_static=None)) as rec:
        rec.write_message(
            "/tf_static",
            TF_MESSAGE,
            MS,
            tf_msg(rec, "base_footprint", "base_link", (0, 0, 0.05), (0, 0, 0, 1)),
        )
        rec.write_message(
            "/tf_static", TF_MESSAGE, MS, tf_msg(rec, "base_link", "/laser", (0.1, 0.02, 0.1), q)
        )
        rec.write_message(
            LASER_SCAN_TOPIC, LASER_SCAN, MS, scan_msg(rec, MS, [1.0] * 5, frame="laser")
        )
    bag = read_bag(tmp_path / "b")
    assert bag.mount.x == pytest.approx(0.1) and bag.mount.y == pytest.approx(0.02)
    assert bag.mount.yaw == pytest.approx(math.pi / 2)
    assert "base_link -> laser" in bag.mount_source
    override = read_bag(tmp_path / "b", mount=Pose2D(0.2, 0.0, 0.0))
    assert override.mount == Pose2D(0.2, 0.0, 0.0) and override.mount_source == "argument"


def test_upside_down_lidar_mirrors_the_scan(tmp_path):
    roll_pi = (1.0, 0.0, 0.0, 0.0)  # rotation by pi about x
    with BagRecorder(tmp_path / "b", topics=TopicMap(tf_static=None)) as rec:
        rec.write_message(
            "/tf_static", TF_MESSAGE, MS, tf_msg(rec, "base_link", "laser", (0.1, 0, 0.1), roll_pi)
        )
        rec.write_message(
            LASER_SCAN_TOPIC,
            LASER_SCAN,
            MS,
            scan_msg(rec, MS, [1.0] * 5, frame="laser", angle_min=-0.5, inc=0.25),
        )
    bag = read_bag(tmp_path / "b")
    assert "upside down" in bag.mount_source
    np.testing.assert_allclose(bag.scans[0].angles, [0.5, 0.25, 0.0, -0.25, -0.5])


def test_missing_tf_falls_back_to_the_kachaka_mount_and_says_so(tmp_path):
    with BagRecorder(tmp_path / "b", topics=TopicMap(tf_static=None)) as rec:
        rec.write_message(
            LASER_SCAN_TOPIC, LASER_SCAN, MS, scan_msg(rec, MS, [1.0] * 5, frame="laser")
        )
    bag = read_bag(tmp_path / "b")
    assert bag.mount == Pose2D(0.156, 0.0, 0.0)
    assert any(n.startswith("mount: default Kachaka lidar mount") for n in bag.notes)


def test_goal_in_map_frame_is_moved_into_odometry_frame(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        rec.write_step(MS, LaserScan(-1.0, 0.5, np.ones(5), 0.05, 10.0), (0, 0, 0), (0, 0))
        map_odom = tf_msg(rec, "map", "odom", (1.0, 0.0, 0.0), quaternion_from_yaw(0.0))
        rec.write_message("/tf", TF_MESSAGE, MS, map_odom)
        pose = rec.message(
            "geometry_msgs/msg/Pose",
            position=rec.message("geometry_msgs/msg/Point", x=3.0, y=1.0, z=0.0),
            orientation=rec.message("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
        )
        goal = rec.message(POSE_STAMPED, header=rec.header(MS, "map"), pose=pose)
        rec.write_message("/goal_pose", POSE_STAMPED, 2 * MS, goal)
    xy, source = first_goal(read_bag(tmp_path / "b"))
    np.testing.assert_allclose(xy, [2.0, 1.0])
    assert "map -> odom" in source


@pytest.mark.parametrize("kind", ["missing", "garbage_bag", "garbage_db3", "no_metadata"])
def test_unreadable_bags_raise_bag_format_error_naming_the_bag(tmp_path, kind):
    path = {
        "missing": tmp_path / "nope",
        "garbage_bag": tmp_path / "junk.bag",
        "garbage_db3": tmp_path / "junk.db3",
        "no_metadata": tmp_path / "emptydir",
    }[kind]
    if kind.startswith("garbage"):
        path.write_bytes(b"this is not a bag" * 20)
    if kind == "no_metadata":
        path.mkdir()
    with pytest.raises(BagFormatError, match=str(path.name)):
        read_bag(path)


def test_bag_without_laserscan_is_an_error(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        rec.write_odometry(MS, (0, 0, 0), (0, 0))
    with pytest.raises(
        BagFormatError, match=r"b: no usable sensor_msgs/msg/LaserScan.*odometry/odometry"
    ):
        read_bag(tmp_path / "b")


def test_corrupt_message_is_counted_and_skipped(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        for k in range(1, 5):
            msg = scan_msg(rec, k * 100 * MS, [1.0] * 10)
            if k == 2:
                raw = bytes(rec.typestore.serialize_cdr(msg, LASER_SCAN))
                rec.write_raw(LASER_SCAN_TOPIC, LASER_SCAN, k * 100 * MS, raw[:30])
            else:
                rec.write_message(LASER_SCAN_TOPIC, LASER_SCAN, k * 100 * MS, msg)
    bag = read_bag(tmp_path / "b")
    assert bag.corrupt == {LASER_SCAN_TOPIC: 1}
    assert len(bag.scans) == 3 and bag.scan_messages == 4
    assert bag.scan_rejects == [(200 * MS, "corrupt message")]
    assert any("1 corrupt message(s) skipped" in n for n in bag.notes)


def test_all_scans_corrupt_is_an_error(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        rec.write_raw(LASER_SCAN_TOPIC, LASER_SCAN, MS, b"\x00\x01\x00\x00\x07")
    with pytest.raises(BagFormatError, match=r"/kachaka/lidar/scan.*all 1 messages are corrupt"):
        read_bag(tmp_path / "b")


def test_zero_beam_scan_is_rejected_with_reason(tmp_path):
    with BagRecorder(tmp_path / "b") as rec:
        rec.write_message(LASER_SCAN_TOPIC, LASER_SCAN, MS, scan_msg(rec, MS, []))
        rec.write_message(LASER_SCAN_TOPIC, LASER_SCAN, 2 * MS, scan_msg(rec, 2 * MS, [1.0]))
    bag = read_bag(tmp_path / "b")
    assert bag.scan_rejects == [(MS, "zero beams")]
    assert len(bag.scans) == 1


def test_frames_argument_changes_recorded_frame_names(tmp_path):
    frames = Frames(lidar="laser_frame", base="base_footprint")
    with BagRecorder(tmp_path / "b", frames=frames) as rec:
        rec.write_step(MS, LaserScan(-1.0, 0.5, np.ones(5), 0.05, 10.0), (0, 0, 0), (0, 0))
    bag = read_bag(tmp_path / "b")
    assert bag.scan_frame_id == "laser_frame"
    assert "base_footprint -> laser_frame" in bag.mount_source
