"""A policy trained behind a scan filter (``TrainConfig.scan_filter``, beyond the paper,
docs/design/scan-filter.md#scan-filter) is driven only behind the same filter: its files record the filter
(meta.json, config.json, the ONNX metadata), every controller built from it carries it, and
``run``, ``eval``/``sweep``, ``replay`` and ``drive`` refuse another one in one line before
any step. A policy trained without a filter runs behind any (the filter applies to every
method alike, issue 40 part 5)."""

from __future__ import annotations

import json
from pathlib import Path

import onnx
import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, run_episode
from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents.onnx_export import export_onnx
from d3dwa_bullet.learning.agents.onnx_policy import METADATA_KEYS, onnx_metadata
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.world.registry import load_world
from tests.support.held_policy import held_checkpoint
from transfer.sim_bridge import ReplayPipeline

FILTER = "speckle+median"


@pytest.fixture(scope="module")
def filtered(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(a checkpoint trained behind FILTER, its ONNX export)."""
    root = tmp_path_factory.mktemp("filtered")
    checkpoint = held_checkpoint(root / "policy", recovery="none", scan_filter=FILTER)
    return checkpoint, export_onnx(checkpoint, root / "filtered.onnx").file


def _one_line(err: pytest.ExceptionInfo, *names: object) -> None:
    message = str(err.value)
    assert "\n" not in message, message
    for name in names:
        assert str(name) in message, (name, message)


def test_the_controllers_carry_the_filter_and_say_so(filtered) -> None:
    checkpoint, file = filtered
    for controller in (
        make_controller("d3dwa", checkpoint),
        make_controller("d3dwa", onnx=file),
    ):
        assert controller.scan_filter == FILTER
        assert f"trained behind the scan filter '{FILTER}'" in controller.source
    plain = make_controller("d3dwa", held_checkpoint(checkpoint.parent / "plain", recovery="none"))
    assert plain.scan_filter == "none" and "scan filter" not in plain.source


def test_the_export_is_a_version_3_file_only_when_it_has_a_filter(filtered, tmp_path) -> None:
    props = {p.key: p.value for p in onnx.load(filtered[1]).metadata_props}
    assert props[METADATA_KEYS["scan_filter"]] == FILTER
    assert props[METADATA_KEYS["format_version"]] == "3"  # a version-2 runner refuses it
    plain = export_onnx(held_checkpoint(tmp_path / "plain", recovery="none"), tmp_path / "p.onnx")
    plain_props = {p.key: p.value for p in onnx.load(plain.file).metadata_props}
    assert METADATA_KEYS["scan_filter"] not in plain_props
    assert plain_props[METADATA_KEYS["format_version"]] == "2"
    assert onnx_metadata(plain.file)["scan_filter"] == "none"


def test_a_version_3_file_without_its_filter_key_is_refused(filtered, tmp_path) -> None:
    model = onnx.load(filtered[1])
    kept = {p.key: p.value for p in model.metadata_props if p.key != METADATA_KEYS["scan_filter"]}
    del model.metadata_props[:]
    onnx.helper.set_model_props(model, kept)
    stripped = tmp_path / "stripped.onnx"
    stripped.write_bytes(model.SerializeToString())
    with pytest.raises(CheckpointError) as err:
        onnx_metadata(stripped)
    _one_line(err, stripped, METADATA_KEYS["scan_filter"])


@pytest.mark.parametrize("bad", ["spek", 3, {"median": 3}, ["median"]])
def test_a_malformed_recorded_filter_is_refused_in_one_line(tmp_path, bad) -> None:
    folder = held_checkpoint(tmp_path / "p", recovery="none", scan_filter=bad)
    with pytest.raises(CheckpointError) as err:
        make_controller("d3dwa", folder)
    _one_line(err, folder / "meta.json", "metadata.scan_filter", "scan filter")


def test_meta_and_config_must_agree_on_the_filter(filtered, tmp_path) -> None:
    folder = held_checkpoint(tmp_path / "p", recovery="none", scan_filter=FILTER)
    config = {"method": "d3dwa", "seed": 0, "decision_steps": 10, "recovery": "none"}
    (folder / "config.json").write_text(json.dumps({**config, "scan_filter": FILTER}))
    assert folder_terms(folder)["scan_filter"] == FILTER
    (folder / "config.json").write_text(json.dumps(config))  # config.json says: none
    with pytest.raises(CheckpointError) as err:
        folder_terms(folder)
    _one_line(err, "metadata.scan_filter", FILTER, "config.json")


def test_an_episode_or_a_replay_behind_another_filter_is_refused(filtered) -> None:
    controller = make_controller("d3dwa", filtered[0])
    for running in ("none", "median"):
        with pytest.raises(ConfigError) as err:
            run_episode(load_world("R1"), controller, config=EpisodeConfig(scan_filter=running))
        _one_line(err, f"--scan-filter {FILTER}", repr(running))
        with pytest.raises(ConfigError) as err:
            ReplayPipeline(controller, config=EpisodeConfig(scan_filter=running))
        _one_line(err, f"--scan-filter {FILTER}", repr(running))
    assert (
        ReplayPipeline(controller, config=EpisodeConfig(scan_filter=FILTER)).scan_filter.name
        == FILTER
    )
    # a policy trained without a filter is driven behind one (every method alike)
    plain = make_controller("d3dwa", held_checkpoint(filtered[0].parent / "p2", recovery="none"))
    assert ReplayPipeline(plain, config=EpisodeConfig(scan_filter=FILTER)).controller is plain


@pytest.mark.parametrize("command", ["run", "eval"])
def test_the_cli_refuses_it_before_any_episode(filtered, tmp_path, capsys, command) -> None:
    out = tmp_path / "out"
    where = ["--world", "TS1"] if command == "run" else ["--worlds", "TS1", "--out", str(out)]
    method = ["--method", "d3dwa"] if command == "run" else ["--methods", "d3dwa"]
    assert main([command, *method, "--policy", str(filtered[0]), *where]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--scan-filter {FILTER}" in err, err
    assert not (out / "results.csv").exists()
