"""What a sweep records in its meta.json before its first episode: one home for the sweep and
a sequential plan's run of it (:mod:`d3dwa_bullet.evaluation.plans.sweep_plan`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation.policy_config import policy_config_notes
from d3dwa_bullet.evaluation.policy_runs import method_runs, policy_digests
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.evaluation.training_worlds import SETTINGS_KEY, runs_barn_training, settings_entry
from d3dwa_bullet.external.resolve import method_origins
from d3dwa_bullet.learning.agents.barn_record import BarnTraining


def sweep_meta(
    settings: SweepSettings, config: EpisodeConfig, policy: str | None, command: str
) -> tuple[dict[str, Any], dict[str, BarnTraining]]:
    """(the sweep's meta.json settings, the BARN training of its runs). Every method's
    controller is made first, so a missing policy fails before anything is written."""
    runs = method_runs(settings.methods, policy, settings.policy_seeds, settings.policy_root)
    for run in runs:
        make_controller(run.method, run.policy)  # fail fast on a missing policy
    meta = {"kind": "sweep", "command": command} | settings.to_dict()
    meta["policy_digests"] = policy_digests(runs)
    meta["method_sources"] = method_origins(settings.methods)
    if policy:
        meta["policy"] = str(Path(policy).resolve())
    meta["policy_notes"] = policy_config_notes(
        runs, config.recovery_name, policy or settings.policy_root
    )
    training = runs_barn_training(runs)
    meta[SETTINGS_KEY] = settings_entry(training)
    return meta, training
