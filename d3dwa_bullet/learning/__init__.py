"""The learning layer: the Gymnasium env, its task sampling and reward, the agents, training.

Modules: ``env`` (``D3DWAEnv``, registered as ``d3dwa_bullet/D3DWA-v0``), ``tasks``
(world, generator, noise and route-start sampling; the training-world guard), ``reward``
(R1 + R2 + R3, pure: no torch, no pybullet), ``render`` (the env's top-down frames, numpy
and OpenCV), ``agents/`` (D3QN, DQDWA, checkpoints, greedy policies) and ``training/``
(``train``, ``TrainConfig``).

The names below are re-exported lazily: each is imported on first access, so importing
``d3dwa_bullet.learning.reward`` (which runs this file first) pulls in neither torch nor
pybullet. The ``reward`` function is not re-exported: it would hide the module of that name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from d3dwa_bullet.lazy import lazy_exports

if TYPE_CHECKING:
    from d3dwa_bullet.learning.env import D3DWAEnv, observation_space
    from d3dwa_bullet.learning.reward import OUTCOMES
    from d3dwa_bullet.learning.tasks import (
        EVAL_ONLY_GROUPS,
        TRAIN_WORLDS,
        EpisodeTask,
        TaskSampler,
        check_training_world,
        resolve_world,
    )
    from d3dwa_bullet.learning.training import (
        TrainConfig,
        Trainer,
        export_policy,
        load_train_config,
        train,
    )

_HOMES = {
    "D3DWAEnv": "d3dwa_bullet.learning.env",
    "observation_space": "d3dwa_bullet.learning.env",
    "OUTCOMES": "d3dwa_bullet.learning.reward",
    "EVAL_ONLY_GROUPS": "d3dwa_bullet.learning.tasks",
    "TRAIN_WORLDS": "d3dwa_bullet.learning.tasks",
    "EpisodeTask": "d3dwa_bullet.learning.tasks",
    "TaskSampler": "d3dwa_bullet.learning.tasks",
    "check_training_world": "d3dwa_bullet.learning.tasks",
    "resolve_world": "d3dwa_bullet.learning.tasks",
    "TrainConfig": "d3dwa_bullet.learning.training",
    "Trainer": "d3dwa_bullet.learning.training",
    "export_policy": "d3dwa_bullet.learning.training",
    "load_train_config": "d3dwa_bullet.learning.training",
    "train": "d3dwa_bullet.learning.training",
}
"""Re-exported name -> the module that defines (or re-exports) it."""

__all__ = [
    "EVAL_ONLY_GROUPS",
    "OUTCOMES",
    "TRAIN_WORLDS",
    "D3DWAEnv",
    "EpisodeTask",
    "TaskSampler",
    "TrainConfig",
    "Trainer",
    "check_training_world",
    "export_policy",
    "load_train_config",
    "observation_space",
    "resolve_world",
    "train",
]


# Imported on first access: env needs pybullet and training needs torch.
__getattr__, __dir__ = lazy_exports(globals(), _HOMES)
