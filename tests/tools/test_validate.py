"""The 25-case validation instrument: its cases are training material only."""

from d3dwa_bullet.learning.tasks import resolve_world
from d3dwa_bullet.world.registry import world_names
from tools.experiments.validate import VALIDATION_WORLDS


def test_validation_cases_are_training_material_only():
    assert len(set(VALIDATION_WORLDS)) == len(VALIDATION_WORLDS) == 25
    evaluation_only = set(world_names("unseen", "real"))
    assert not evaluation_only & set(VALIDATION_WORLDS)
    for name in VALIDATION_WORLDS:  # ConfigError if an evaluation-only world slipped in
        resolve_world(name, False, "validation")
