"""Worlds: obstacles, start and goal; their files, grids, routes and generated layouts.

Modules inside this package import each other directly (``d3dwa_bullet.world.model``),
never through this ``__init__``, which only re-exports the public names for callers.
(``route_start`` is not re-exported: its function would hide the module of that name.)
"""

from d3dwa_bullet.world.barn import barn_split, barn_split_ids, barn_world
from d3dwa_bullet.world.gaps import Passage, gap_between, passages
from d3dwa_bullet.world.generator import (
    UNSEEN_LAYOUT_SEED_BASE,
    generate_world,
    generated_world_from_name,
)
from d3dwa_bullet.world.generator_spec import GeneratorSpec, list_generator_styles, load_generator
from d3dwa_bullet.world.grid import Grid, clearance_field, rasterize
from d3dwa_bullet.world.map_server import load_map_world
from d3dwa_bullet.world.model import (
    Box,
    Cylinder,
    Obstacle,
    World,
    obstacle_distance,
    obstacle_extent,
    obstacle_outline,
    validate_task,
)
from d3dwa_bullet.world.native import GROUPS, world_from_dict
from d3dwa_bullet.world.reachability import footprint_reachable
from d3dwa_bullet.world.registry import (
    list_worlds,
    load_world,
    load_world_file,
    world_file_kind,
    world_names,
    world_paths,
)
from d3dwa_bullet.world.routes import ShortestPath, geodesic_field, shortest_path
from d3dwa_bullet.world.sdf import load_sdf_world

__all__ = [
    "GROUPS",
    "UNSEEN_LAYOUT_SEED_BASE",
    "Box",
    "Cylinder",
    "GeneratorSpec",
    "Grid",
    "Obstacle",
    "Passage",
    "ShortestPath",
    "World",
    "barn_split",
    "barn_split_ids",
    "barn_world",
    "clearance_field",
    "footprint_reachable",
    "gap_between",
    "generate_world",
    "generated_world_from_name",
    "geodesic_field",
    "list_generator_styles",
    "list_worlds",
    "load_generator",
    "load_map_world",
    "load_sdf_world",
    "load_world",
    "load_world_file",
    "obstacle_distance",
    "obstacle_extent",
    "obstacle_outline",
    "passages",
    "rasterize",
    "shortest_path",
    "validate_task",
    "world_file_kind",
    "world_from_dict",
    "world_names",
    "world_paths",
]
