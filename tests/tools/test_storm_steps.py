"""storm_steps re-runs a sweep's episodes with the policies, layer and filter the sweep ran."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.policy_runs import PolicyRun, policy_digests
from d3dwa_bullet.resources import policies_dir
from tools.experiments.storm_steps import episode_config, policies_of


def _sweep_meta(policy: Path | None, digest: str) -> dict:
    settings = {"recovery": "nav2", "policy_digests": {"d3dwa-dr/seed-0": digest}}
    if policy is not None:
        settings["policy"] = str(policy)
    return {"config": {"scan_filter": "speckle+median"}, "settings": settings}


def _copy_seed(tmp_path: Path) -> tuple[Path, str]:
    folder = tmp_path / "mine"
    shutil.copytree(policies_dir() / "d3dwa-dr" / "seed-0", folder / "seed-0")
    run = PolicyRun("d3dwa-dr", 0, str(folder / "seed-0"))
    return folder, policy_digests([run])["d3dwa-dr/seed-0"]


def test_the_policy_folder_the_sweep_named_is_the_one_re_run(tmp_path: Path) -> None:
    folder, digest = _copy_seed(tmp_path)
    meta = _sweep_meta(folder, digest)
    assert policies_of(tmp_path, meta, "d3dwa-dr", {0}) == {0: str(folder / "seed-0")}
    assert policies_of(tmp_path, meta, "dwa3", set()) == {None: None}


def test_weights_other_than_the_sweeps_are_refused(tmp_path: Path) -> None:
    folder, digest = _copy_seed(tmp_path)
    meta = _sweep_meta(folder, "0" * 64)
    with pytest.raises(ResultsError, match="d3dwa-dr/seed-0's weights are not the ones"):
        policies_of(tmp_path, meta, "d3dwa-dr", {0})
    assert digest != "0" * 64


def test_the_sweeps_layer_and_scan_filter_are_kept(tmp_path: Path) -> None:
    config = episode_config(tmp_path, _sweep_meta(None, ""))  # no meta.json: read once, given
    assert config.scan_filter == "speckle+median"
    assert config.recovery is not None and config.recovery.kind == "nav2"
