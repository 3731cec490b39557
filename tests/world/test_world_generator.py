"""R1-R3 style layout generators: determinism, constraints, passability, bad input."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import yaml

from d3dwa_bullet.errors import ConfigError, UnknownNameError, WorldFormatError
from d3dwa_bullet.resources import generators_dir
from d3dwa_bullet.world import generator as world_generator
from d3dwa_bullet.world.gaps import gap_between
from d3dwa_bullet.world.generator import generate_world
from d3dwa_bullet.world.generator_spec import list_generator_styles, load_generator
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.reachability import footprint_reachable
from d3dwa_bullet.world.routes import shortest_path

STYLES = ["R1-style", "R2-style", "R3-style"]
COUNTS = {"R1-style": 5, "R2-style": 8, "R3-style": 14}
GOALS = {"R1-style": (3.0, 0.0), "R2-style": (2.5, 0.25), "R3-style": (3.0, -1.0)}
SEEDS = [0, 17]


@cache
def generated(style: str, seed: int) -> World:
    return generate_world(style, seed)


def test_styles_are_listed():
    assert list_generator_styles() == STYLES


@pytest.mark.parametrize("style", STYLES)
@pytest.mark.parametrize("seed", SEEDS)
def test_generated_world_identity(style, seed):
    w = generated(style, seed)
    assert w.name == f"{style}-s{seed}"
    assert w.group == "custom"
    assert w.source == f"generator {style} seed {seed}"
    assert w.start == (0.0, 0.0, 0.0) and w.goal == GOALS[style]
    assert len(w.obstacles) == COUNTS[style]


@pytest.mark.parametrize("style", STYLES)
def test_same_seed_same_world(style):
    assert generate_world(style, SEEDS[0]) == generated(style, SEEDS[0])


@pytest.mark.parametrize("style", STYLES)
def test_different_seeds_differ(style):
    assert generated(style, SEEDS[0]).obstacles != generated(style, SEEDS[1]).obstacles


@pytest.mark.parametrize("style", STYLES)
@pytest.mark.parametrize("seed", SEEDS)
def test_generated_world_respects_its_style(style, seed):
    spec = load_generator(style)
    w = generated(style, seed)
    ends = np.array([w.start[:2], w.goal])
    assert (w.distance(ends) >= spec.clear_endpoints - 1e-9).all()
    obs = w.obstacles
    for i in range(len(obs)):
        for j in range(i + 1, len(obs)):
            g = gap_between(obs[i], obs[j])
            assert g >= spec.min_gap - 1e-9 or 0 < g <= spec.closed_gap + 1e-9, (i, j, g)
    length = shortest_path(w).length
    assert spec.path_length[0] <= length <= spec.path_length[1]
    if spec.footprint_check:
        assert footprint_reachable(w)


def test_rows_are_staggered():
    spec = load_generator("R2-style")
    w = generated("R2-style", SEEDS[0])
    xs = np.array([ob.center[0] for ob in w.obstacles])
    for k, x in enumerate(spec.rows.x):
        row = xs[k * spec.rows.per_row : (k + 1) * spec.rows.per_row]
        assert np.all(np.abs(row - x) <= spec.rows.x_jitter + 1e-9)


def test_unknown_style():
    with pytest.raises(UnknownNameError, match="R1-style"):
        generate_world("R9-style", 0)


@pytest.mark.parametrize("seed", [-1, 1.5, "3"])
def test_bad_seed(seed):
    with pytest.raises(ConfigError, match="seed"):
        generate_world("R1-style", seed)


def style_data(style="R1-style"):
    return yaml.safe_load((generators_dir() / f"{style}.yaml").read_text())


@pytest.mark.parametrize(
    ("style", "key", "value", "field"),
    [
        ("R1-style", "layout", None, "layout"),
        ("R1-style", "layout", "grid", "layout"),
        ("R1-style", "goal", [1.0], "goal"),
        ("R1-style", "count", 0, "count"),
        ("R1-style", "region", [2.0, 0.0, 1.0, 1.0], "region"),
        ("R1-style", "box_side", [0.5, 0.2], "box_side"),
        ("R1-style", "cylinder_radius", [-0.1, 0.2], "cylinder_radius"),
        ("R1-style", "shapes", {"sphere": 1.0}, "shapes"),
        ("R1-style", "min_gap", None, "min_gap"),
        ("R1-style", "closed_gap", 0.9, "closed_gap"),
        ("R2-style", "rows", None, "rows"),
        ("R2-style", "rows", {"x": [1.0], "gap": [0.5, 0.6]}, "per_row"),
        (
            "R3-style",
            "line",
            {"count": 3, "first": [0, 0, 1, 1], "heading": [0, 1], "gap": [0.1, 0.5]},
            "gap",
        ),
    ],
)
def test_malformed_style_file(tmp_path, style, key, value, field):
    data = style_data(style)
    if value is None:
        del data[key]
    else:
        data[key] = value
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(WorldFormatError, match=f"'{field}'") as err:
        generate_world(str(path), 0)
    assert str(path) in str(err.value)


def test_custom_style_file(tmp_path):
    data = style_data("R1-style") | {"style": "mine", "count": 2}
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(data))
    w = generate_world(str(path), 3)
    assert w.name == "mine-s3" and len(w.obstacles) == 2


def test_impossible_style_gives_up(tmp_path, monkeypatch):
    monkeypatch.setattr(world_generator, "LAYOUT_ATTEMPTS", 3)
    monkeypatch.setattr(world_generator, "PLACEMENT_ATTEMPTS", 5)
    data = style_data("R1-style") | {"count": 40, "min_gap": 0.9}
    path = tmp_path / "crowded.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="no passable layout"):
        generate_world(str(path), 0)
