"""World file formats: native YAML errors, Gazebo SDF and ROS map_server maps."""

from __future__ import annotations

import math
import warnings

import cv2
import numpy as np
import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import WorldFormatError
from d3dwa_bullet.world.map_server import load_map_world, mask_to_boxes
from d3dwa_bullet.world.model import Box, Cylinder
from d3dwa_bullet.world.registry import load_world_file
from d3dwa_bullet.world.sdf import DEFAULT_GOAL, DEFAULT_START, load_sdf_world

# ---------------------------------------------------------------- native YAML

GOOD = {
    "name": "T",
    "group": "custom",
    "description": "a test world",
    "start": [0.0, 0.0, 0.0],
    "goal": [2.0, 0.0],
    "obstacles": [
        {"type": "box", "center": [1.0, 0.8], "size": [0.4, 0.3]},
        {"type": "cylinder", "center": [1.0, -0.8], "radius": 0.2},
        {"type": "wall", "start": [-1, 1.5], "end": [3, 1.5]},
    ],
}


def write_native(tmp_path, data, name="world.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def with_change(key, value):
    data = {k: (list(v) if isinstance(v, list) else v) for k, v in GOOD.items()}
    data["obstacles"] = [dict(o) for o in GOOD["obstacles"]]
    if key.startswith("obstacles."):
        _, index, field = key.split(".")
        if value is None:
            del data["obstacles"][int(index)][field]
        else:
            data["obstacles"][int(index)][field] = value
    elif value is None:
        del data[key]
    else:
        data[key] = value
    return data


def test_good_native_world_loads(tmp_path):
    w = load_world_file(write_native(tmp_path, GOOD))
    assert (w.name, w.group, w.goal) == ("T", "custom", (2.0, 0.0))
    assert isinstance(w.obstacles[0], Box) and isinstance(w.obstacles[1], Cylinder)
    wall = w.obstacles[2]
    assert wall.size == pytest.approx((4.1, 0.1)) and wall.center == pytest.approx((1.0, 1.5))


@pytest.mark.parametrize(
    ("key", "value", "field"),
    [
        ("name", None, "name"),
        ("description", None, "description"),
        ("start", None, "start"),
        ("goal", None, "goal"),
        ("goal", [1.0], "goal"),
        ("start", [0.0, "x", 0.0], "start"),
        ("group", "training", "group"),
        ("order", -1, "order"),
        ("order", 1.5, "order"),
        ("order", True, "order"),
        ("obstacles", {"type": "box"}, "obstacles"),
        ("time_limit", -5, "time_limit"),
        ("obstacles.0.size", [-0.4, 0.3], "size"),
        ("obstacles.0.size", None, "size"),
        ("obstacles.0.type", "sphere", "type"),
        ("obstacles.0.height", 0, "height"),
        ("obstacles.1.radius", -0.2, "radius"),
        ("obstacles.1.center", [1.0], "center"),
        ("obstacles.2.thickness", -0.1, "thickness"),
        ("goal", [1.0, 0.8], "goal"),  # inside the box
        ("start", [1.0, -0.7, 0.0], "start"),  # inside the cylinder
        ("start", [0.75, 0.8, 0.0], "start"),  # body overlaps the box
    ],
)
def test_malformed_native_world(tmp_path, key, value, field):
    path = write_native(tmp_path, with_change(key, value))
    with pytest.raises(WorldFormatError, match=f"'{field}'") as err:
        load_world_file(path)
    assert str(path) in str(err.value)


def test_not_a_mapping(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- 1\n- 2\n")
    with pytest.raises(WorldFormatError, match="mapping"):
        load_world_file(path)


# ---------------------------------------------------------------- Gazebo SDF

SDF = """<?xml version="1.0"?>
<sdf version="1.6">
  <world name="test">
    <include><uri>model://ground_plane</uri></include>
    <include><uri>model://sun</uri></include>
    <model name="crate">
      <static>true</static>
      <pose>1.0 2.0 0 0 0 1.5707963267948966</pose>
      <link name="body">
        <pose>0.5 0 0 0 0 0</pose>
        <collision name="c">
          <pose>0 0 0.25 0 0 0.1</pose>
          <geometry><box><size>0.6 0.2 0.5</size></box></geometry>
        </collision>
        <visual name="v"><geometry><box><size>0.6 0.2 0.5</size></box></geometry></visual>
      </link>
    </model>
    <model name="post">
      <pose>-1.0 0.5 0 0 0 0</pose>
      <link name="l">
        <collision name="c">
          <pose>0 0 0.4 0 0 0</pose>
          <geometry><cylinder><radius>0.15</radius><length>0.8</length></cylinder></geometry>
        </collision>
      </link>
    </model>
    <model name="ball">
      <link name="l">
        <collision name="c"><geometry><sphere><radius>0.1</radius></sphere></geometry></collision>
      </link>
    </model>
  </world>
</sdf>
"""


def load_sdf_text(tmp_path, text, **kw):
    path = tmp_path / "test.world"
    path.write_text(text)
    return path, load_sdf_world(path, **kw)


def test_sdf_boxes_and_cylinders(tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        path, w = load_sdf_text(tmp_path, SDF)
    assert len(caught) == 1
    message = str(caught[0].message)
    for item in ("ground_plane", "sun", "sphere", "ball"):
        assert item in message
    assert (w.name, w.group, w.source) == ("test", "custom", str(path))
    assert w.start == DEFAULT_START and w.goal == DEFAULT_GOAL
    crate, post = w.obstacles
    # model (1, 2, 90 deg) then link x += 0.5 -> (1, 2.5); collision adds 0.1 rad of yaw
    assert isinstance(crate, Box)
    assert crate.center == pytest.approx((1.0, 2.5))
    assert crate.size == pytest.approx((0.6, 0.2))
    assert crate.yaw == pytest.approx(math.pi / 2 + 0.1)
    assert crate.height == pytest.approx(0.5)
    assert isinstance(post, Cylinder)
    assert post.center == pytest.approx((-1.0, 0.5)) and post.radius == pytest.approx(0.15)
    assert post.height == pytest.approx(0.8)
    # the crate's long side now runs along y: 0.3 m from its centre along y is its surface
    yaw = math.pi / 2 + 0.1
    edge = np.array([[1.0 + 0.3 * math.cos(yaw), 2.5 + 0.3 * math.sin(yaw)]])
    assert w.distance(edge)[0] == pytest.approx(0.0, abs=1e-9)


def test_sdf_through_load_world_file_and_with_task(tmp_path):
    path = tmp_path / "scene.world"
    path.write_text(SDF)
    with pytest.warns(UserWarning):
        w = load_world_file(path)
    assert w.name == "scene"
    moved = w.with_task(start=(0.0, 0.0, 0.0), goal=(3.0, 0.0))
    assert moved.goal == (3.0, 0.0)
    with pytest.raises(WorldFormatError, match="'goal'"):
        w.with_task(goal=(1.0, 2.5))


def test_sdf_given_task_is_validated(tmp_path):
    with pytest.warns(UserWarning), pytest.raises(WorldFormatError, match="'start'"):
        load_sdf_text(tmp_path, SDF, start=(-1.0, 0.5, 0.0), goal=(3.0, 0.0))


def test_sdf_without_skipped_items_does_not_warn(tmp_path):
    text = SDF.replace("<include><uri>model://ground_plane</uri></include>", "")
    text = text.replace("<include><uri>model://sun</uri></include>", "")
    text = text[: text.index('<model name="ball">')] + "</world></sdf>"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, w = load_sdf_text(tmp_path, text)
    assert len(w.obstacles) == 2


NESTED = """<sdf version="1.7"><world name="w">
<model name="outer"><pose>1 0 0 0 0 1.5707963267948966</pose>
  <model name="inner"><pose>1 0 0 0 0 0</pose>
    <link name="l">
      <collision name="low"><pose>0 0 0.05 0 0 0</pose>
        <geometry><box><size>0.2 0.4 0.5</size></box></geometry></collision>
      <collision name="lamp"><pose>0 0 2.5 0 0 0</pose>
        <geometry><cylinder><radius>0.1</radius><length>0.2</length></cylinder></geometry></collision>
      <collision name="pit"><pose>0 0 -1 0 0 0</pose>
        <geometry><cylinder><radius>0.1</radius><length>0.2</length></cylinder></geometry></collision>
    </link>
  </model>
</model></world></sdf>"""


def test_sdf_nested_models_and_heights(tmp_path):
    with pytest.warns(UserWarning, match="lamp.*above the robot.*pit.*below the floor"):
        _, w = load_sdf_text(tmp_path, NESTED)
    (box,) = w.obstacles
    # outer turns the inner model's +x offset into +y
    assert box.center == pytest.approx((1.0, 1.0))
    assert box.yaw == pytest.approx(math.pi / 2)
    assert box.height == pytest.approx(0.3)  # stands on the floor up to its top


BOX_MODEL = """<sdf version="1.6"><world name="w"><model name="crate"><link name="l">
<collision name="c"><geometry>{geometry}</geometry></collision></link></model></world></sdf>"""


@pytest.mark.parametrize(
    ("geometry", "field"),
    [
        ("<box><size>0.5 -0.2 0.5</size></box>", "size"),
        ("<box></box>", "size"),
        ("<box><size>0.5 0.5</size></box>", "size"),
        ("<box><size>a b c</size></box>", "size"),
        ("<cylinder><length>0.5</length></cylinder>", "radius"),
        ("<cylinder><radius>0</radius><length>0.5</length></cylinder>", "radius"),
        ("<cylinder><radius>0.2</radius></cylinder>", "length"),
        ("", "geometry"),
    ],
)
def test_malformed_sdf_model(tmp_path, geometry, field):
    path = tmp_path / "bad.world"
    path.write_text(BOX_MODEL.format(geometry=geometry))
    with pytest.raises(WorldFormatError, match=f"'{field}'") as err:
        load_sdf_world(path)
    assert str(path) in str(err.value) and "crate" in str(err.value)


@pytest.mark.parametrize(
    "text",
    ['<sdf><world name="w"><model name="m">', "<sdf><model/></sdf>", "not xml at all"],
)
def test_malformed_sdf_file(tmp_path, text):
    path = tmp_path / "bad.sdf"
    path.write_text(text)
    with pytest.raises(WorldFormatError, match="bad.sdf"):
        load_world_file(path)


def test_sdf_bad_pose(tmp_path):
    text = SDF.replace("<pose>-1.0 0.5 0 0 0 0</pose>", "<pose>-1.0 0.5</pose>")
    path = tmp_path / "pose.world"
    path.write_text(text)
    with pytest.raises(WorldFormatError, match="post.*'pose'"):
        load_sdf_world(path)


# ---------------------------------------------------------------- map_server

MAP_YAML = {
    "image": "map.pgm",
    "resolution": 0.05,
    "origin": [-1.0, -0.5, 0.0],
    "negate": 0,
    "occupied_thresh": 0.65,
    "free_thresh": 0.196,
}
ROWS, COLS = 30, 40
BLOCK = (slice(5, 10), slice(10, 15))  # image rows 5..9, columns 10..14


def write_map(tmp_path, pixels=None, **changes):
    if pixels is None:
        pixels = np.full((ROWS, COLS), 254, dtype=np.uint8)
        pixels[BLOCK] = 0
        pixels[20, 30] = 205  # unknown grey: not an obstacle
    cv2.imwrite(str(tmp_path / "map.pgm"), pixels)
    data = dict(MAP_YAML)
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    path = tmp_path / "lab.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def block_corners(yaw: float, ox: float = -1.0, oy: float = -0.5) -> np.ndarray:
    """World corners of BLOCK: columns 10..14 -> x 0.5..0.75, rows 5..9 -> y 1.0..1.25 (map frame)."""
    local = np.array([[0.5, 1.0], [0.75, 1.0], [0.75, 1.25], [0.5, 1.25]])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack(
        (ox + c * local[:, 0] - s * local[:, 1], oy + s * local[:, 0] + c * local[:, 1])
    )


@pytest.mark.parametrize("yaw", [0.0, 0.7, math.pi / 2])
def test_map_obstacle_lands_in_the_right_place(tmp_path, yaw):
    w = load_world_file(write_map(tmp_path, origin=[-1.0, -0.5, yaw]))
    assert (w.name, w.group) == ("lab", "custom")
    assert len(w.obstacles) == 1  # the 5 x 5 block merges into one box
    (box,) = w.obstacles
    assert box.size == pytest.approx((0.25, 0.25)) and box.yaw == pytest.approx(yaw)
    corners = block_corners(yaw)
    assert np.allclose(w.distance(corners), 0.0, atol=1e-9)
    assert w.distance(corners.mean(axis=0, keepdims=True))[0] == pytest.approx(-0.125)
    outward = corners + 0.1 * (corners - corners.mean(axis=0))
    assert (w.distance(outward) > 0).all()


def test_map_negate_and_thresholds(tmp_path):
    pixels = np.zeros((ROWS, COLS), dtype=np.uint8)
    pixels[BLOCK] = 255
    w = load_map_world(write_map(tmp_path, pixels=pixels, negate=1))
    assert len(w.obstacles) == 1
    assert np.allclose(w.distance(block_corners(0.0)), 0.0, atol=1e-9)
    grey = np.full((ROWS, COLS), 254, dtype=np.uint8)
    grey[BLOCK] = 100  # p = 0.61: occupied only below that threshold
    assert len(load_map_world(write_map(tmp_path, pixels=grey)).obstacles) == 0
    assert len(load_map_world(write_map(tmp_path, pixels=grey, occupied_thresh=0.5)).obstacles) == 1


def test_map_task_defaults_and_override(tmp_path):
    path = write_map(tmp_path)
    w = load_map_world(path)
    assert w.start == DEFAULT_START and w.goal == DEFAULT_GOAL
    inside = tuple(block_corners(0.0).mean(axis=0))
    with pytest.raises(WorldFormatError, match="'goal'"):
        load_map_world(path, goal=inside)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"image": None}, "image"),
        ({"resolution": None}, "resolution"),
        ({"origin": None}, "origin"),
        ({"negate": None}, "negate"),
        ({"occupied_thresh": None}, "occupied_thresh"),
        ({"free_thresh": None}, "free_thresh"),
        ({"resolution": 0}, "resolution"),
        ({"resolution": "fine"}, "resolution"),
        ({"origin": [0.0, 0.0]}, "origin"),
        ({"negate": 2}, "negate"),
        ({"occupied_thresh": 0.1}, "free_thresh"),
        ({"mode": "fancy"}, "mode"),
        ({"image": "missing.pgm"}, "image"),
    ],
)
def test_malformed_map(tmp_path, change, field):
    path = write_map(tmp_path, **change)
    with pytest.raises(WorldFormatError, match=f"'{field}'") as err:
        load_map_world(path)  # load_world_file only dispatches here when 'image' is present
    assert str(path) in str(err.value)


def test_unreadable_map_image(tmp_path):
    path = write_map(tmp_path)
    (tmp_path / "map.pgm").write_bytes(b"P5 garbage")
    with pytest.raises(WorldFormatError, match="'image'"):
        load_map_world(path)


@pytest.mark.parametrize("seed", range(5))
def test_mask_to_boxes_covers_the_mask_exactly(seed):
    mask = np.random.default_rng(seed).random((23, 31)) < 0.4
    mask[3:9, 4:12] = True  # a block whose rows merge
    boxes = mask_to_boxes(mask)
    cover = np.zeros(mask.shape, dtype=int)
    for r0, r1, c0, c1 in boxes:
        cover[r0 : r1 + 1, c0 : c1 + 1] += 1
    assert np.array_equal(cover, mask.astype(int))
    assert len(boxes) < mask.sum()


def test_sdf_of_thousands_of_nested_models_is_refused_in_one_line(tmp_path, capsys):
    depth = 5_000
    path = tmp_path / "deep.world"
    path.write_text('<sdf version="1.7"><world name="w">' + '<model name="m">' * depth
                    + "</model>" * depth + "</world></sdf>")  # fmt: skip
    with pytest.raises(WorldFormatError, match=rf"^{path}: <model> is nested more than"):
        load_sdf_world(path)
    assert main(["run", "--world", str(path), "--method", "dwa1"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"d3dwa: error: {path}: <model> is nested more than ")


def test_sdf_with_nested_models_within_the_limit_still_loads(tmp_path):
    depth = 20  # 20 models, each inside the last: 22 + 5 elements deep at the box's size
    inner = ('<link name="l"><collision name="c"><geometry><box><size>0.2 0.2 0.2</size>'
             "</box></geometry></collision></link>")  # fmt: skip
    text = ('<sdf version="1.7"><world name="w">' + '<model name="m"><pose>0.1 0 0 0 0 0</pose>'
            * depth + inner + "</model>" * depth + "</world></sdf>")  # fmt: skip
    _, w = load_sdf_text(tmp_path, text)
    (box,) = w.obstacles
    assert box.center == pytest.approx((0.1 * depth, 0.0))
