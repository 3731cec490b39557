"""Training a learned method (d3dwa, d3dwa-weights, d3dwa-dr, dqdwa) in the D3DWA env.

``train(config, out_dir)`` runs one training from a ``TrainConfig`` (usually a YAML file
in ``configs/``, read with ``load_train_config``) and writes a run directory;
``export_policy`` copies a run's policy to where it is shipped.

Modules: ``config`` (TrainConfig and what it builds), ``run_dir`` (the files of a run),
``logs`` (episodes.csv, metrics.jsonl, learning curve), ``curriculum`` (task weights),
``schedule`` (when to log, evaluate, checkpoint), ``state`` (the resumable state and the
replay that rebuilds it), ``greedy_eval`` (periodic greedy evaluation), ``checkpoints``
(latest, best, final, export), ``collector`` (the envs in lock-step), ``lock_step`` (one
step of them and the transitions it gives the learner) and ``trainer`` (the loop).
"""

from d3dwa_bullet.learning.training.checkpoints import export_policy
from d3dwa_bullet.learning.training.config import (
    TrainConfig,
    check_run_limits,
    load_train_config,
    make_agent,
    make_env,
)
from d3dwa_bullet.learning.training.logs import (
    MetricsLog,
    learning_curve,
    read_episodes,
    read_metrics,
)
from d3dwa_bullet.learning.training.trainer import Trainer, train

__all__ = [
    "MetricsLog",
    "TrainConfig",
    "Trainer",
    "check_run_limits",
    "export_policy",
    "learning_curve",
    "load_train_config",
    "make_agent",
    "make_env",
    "read_episodes",
    "read_metrics",
    "train",
]
