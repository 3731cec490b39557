"""Topic resolution: defaults, fallback by message type, and what gets reported."""

import pytest

from d3dwa_bullet.errors import BagFormatError
from transfer.topics import LASER_SCAN, ODOMETRY, TF_MESSAGE, TopicMap, resolve_topics

DEFAULT = TopicMap()


def kachaka_topics() -> dict[str, str]:
    from transfer.topics import ROLE_TYPES

    return {getattr(DEFAULT, role): ty for role, ty in ROLE_TYPES.items()}


def test_defaults_resolve_without_notes():
    res = resolve_topics(kachaka_topics())
    assert res.topics == {role: getattr(DEFAULT, role) for role in DEFAULT.roles()}
    assert res.notes == []


def test_absent_default_falls_back_to_the_only_topic_of_its_type():
    available = {"/scan": LASER_SCAN, "/odom": ODOMETRY, "/tf": TF_MESSAGE}
    res = resolve_topics(available)
    assert res["scan"] == "/scan"
    assert res["odometry"] == "/odom"
    assert res["wheel_odometry"] is None  # /odom is claimed by odometry
    assert res["tf"] == "/tf"
    assert res["tf_static"] is None  # /tf is claimed by tf
    assert any("scan" in n and "'/scan'" in n and "only" in n for n in res.notes)
    assert any(n.startswith("imu:") and "no other" in n for n in res.notes)


def test_ambiguous_fallback_is_reported_not_guessed():
    res = resolve_topics({"/front/scan_a": LASER_SCAN, "/rear/scan_b": LASER_SCAN})
    assert res["scan"] is None
    assert any("ambiguous" in n and "/front/scan_a" in n for n in res.notes)


def test_ambiguity_broken_by_the_default_basename():
    available = {"/robot/tf": TF_MESSAGE, "/robot/tf_static": TF_MESSAGE}
    res = resolve_topics(available)
    assert res["tf"] == "/robot/tf"
    assert res["tf_static"] == "/robot/tf_static"


def test_explicit_topic_must_exist():
    with pytest.raises(BagFormatError, match=r"'/laser'.*scan.*absent.*'/scan'"):
        resolve_topics({"/scan": LASER_SCAN}, TopicMap(scan="/laser"), bag="x.bag")


def test_explicit_topic_with_wrong_type_is_refused():
    with pytest.raises(BagFormatError, match="has type nav_msgs/msg/Odometry"):
        resolve_topics({"/scan": ODOMETRY}, TopicMap(scan="/scan"))


def test_default_name_with_wrong_type_falls_back():
    available = {DEFAULT.scan: ODOMETRY, "/scan": LASER_SCAN}
    res = resolve_topics(available)
    assert res["scan"] == "/scan"
    assert any("has type nav_msgs/msg/Odometry" in n for n in res.notes)


def test_disabled_role_is_not_auto_selected():
    res = resolve_topics({"/scan": LASER_SCAN, "/imu": "sensor_msgs/msg/Imu"}, TopicMap(imu=None))
    assert res["imu"] is None
    assert not any(n.startswith("imu") for n in res.notes)
