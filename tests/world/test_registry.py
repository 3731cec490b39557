"""The registry: shipped worlds by group and in listing order, from the files' own fields."""

from __future__ import annotations

import pytest
import yaml

import d3dwa_bullet.world as world_package
from d3dwa_bullet.errors import UnknownNameError, WorldFormatError
from d3dwa_bullet.world import registry
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import list_worlds, world_names, world_paths
from d3dwa_bullet.world.routes import shortest_path

#: The order every listing and table printed before the groups came from the files.
LISTING = ("TS1", "TS2", "TS3", "TS4", "US1", "H1", "H2", "H3", "R1", "R2", "R3")


def test_listing_order_is_groups_then_order_field():
    assert world_names() == LISTING
    assert tuple(world_paths()) == LISTING
    assert tuple(w.name for w in list_worlds()) == LISTING


def test_groups_come_from_the_files():
    assert world_names("train") == ("TS1", "TS2", "TS3", "TS4")
    assert world_names("unseen") == ("US1", "H1", "H2", "H3")
    assert world_names("real") == ("R1", "R2", "R3")
    assert world_names("train", "unseen") == LISTING[:8]
    assert world_names("real", "train") == ("TS1", "TS2", "TS3", "TS4", "R1", "R2", "R3")
    assert world_names("custom") == ()
    for w in list_worlds():
        assert w.name in world_names(w.group)


def test_unknown_group_names_the_choices():
    with pytest.raises(UnknownNameError, match="'training'.*train, unseen, real, custom"):
        world_names("training")


def write(folder, name, **fields):
    data = {"name": name, "description": "d", "start": [0, 0, 0], "goal": [1, 0], **fields}
    (folder / f"{name}.yaml").write_text(yaml.safe_dump(data))


def test_key_is_group_then_order_then_file_name(tmp_path):
    write(tmp_path, "b", group="real", order=1)
    write(tmp_path, "a", group="real")  # no order: after those with one
    write(tmp_path, "z", group="train", order=9)
    write(tmp_path, "y", group="train", order=2)
    write(tmp_path, "c")  # custom
    rows = registry._shipped(tmp_path)
    assert [(name, group) for name, group, _ in rows] == [
        ("y", "train"), ("z", "train"), ("b", "real"), ("a", "real"), ("c", "custom")
    ]  # fmt: skip


def test_a_malformed_order_names_the_file(tmp_path):
    write(tmp_path, "bad", group="train", order="first")
    with pytest.raises(WorldFormatError, match="bad.yaml.*'order'"):
        registry._shipped(tmp_path)


def test_the_package_reexports_the_public_names():
    assert (world_package.World, world_package.load_world, world_package.shortest_path) == (
        World,
        registry.load_world,
        shortest_path,
    )
    for name in world_package.__all__:
        assert hasattr(world_package, name), name
