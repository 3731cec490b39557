"""A policy brought with --policy names the config it was trained under on the evaluation page:
the committed one, or its own with how it differs, and a recovery layer it trained inside."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from d3dwa_bullet.evaluation.policy_config import policy_config_notes
from d3dwa_bullet.evaluation.policy_runs import method_runs
from d3dwa_bullet.learning.agents.checkpoint import save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.training.config import load_train_config
from d3dwa_bullet.limits import MAX_NOTE_CHARS
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.resources import configs_dir
from tests.support.cli import run

PNG = bytes.fromhex("89504e470d0a1a0a")  # a PNG signature is enough to copy


def committed_seeds(root: Path, seeds=(0, 1), **changes) -> Path:
    """root/d3dwa/seed-<k>/: an untrained D3QN and the committed d3dwa config (seed k), with
    ``changes`` (dotted names, e.g. ``agent.gamma``) applied to every seed."""
    for k in seeds:
        agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(8,), seed=k))
        config = load_train_config(configs_dir() / "d3dwa.yaml").to_dict()
        config["seed"] = config["agent"]["seed"] = k
        for name, value in changes.items():
            *parent, leaf = name.split(".")
            (config[parent[0]] if parent else config)[leaf] = value
        terms = {n: config[n] for n in ("decision_steps", "recovery")}  # as training records them
        path = save_checkpoint(root / "d3dwa" / f"seed-{k}", agent, terms, method="d3dwa")
        (path / "config.json").write_text(json.dumps(config))
    return root / "d3dwa"


def test_seeds_of_the_committed_config_say_so(tmp_path):
    folder = str(committed_seeds(tmp_path))
    notes = policy_config_notes(method_runs(["d3dwa"], folder), "nav2", folder)
    assert notes == [f"`d3dwa` from `{folder}`: trained under the committed `configs/d3dwa.yaml`."]
    # the committed config trains inside the layer: an evaluation without it says so
    (bare,) = policy_config_notes(method_runs(["d3dwa"], folder), "none", folder)
    assert bare == notes[0] + (
        " It was trained with the recovery layer `nav2`; this evaluation runs with `none`."
    )


def test_a_shipped_policy_is_named_only_for_a_layer_it_did_not_train_in(tmp_path):
    folder = committed_seeds(tmp_path)  # as policies/ holds them: the committed config
    runs = method_runs(["dwa3", "d3dwa"], str(folder))
    trained_in = load_train_config(configs_dir() / "d3dwa.yaml").recovery
    other = "none" if trained_in != "none" else "nav2"
    assert policy_config_notes(runs, trained_in, None) == []
    assert policy_config_notes(runs, other, None) == [
        "The shipped `d3dwa`: trained under `configs/d3dwa.yaml`. It was trained with the "
        f"recovery layer `{trained_in}`; this evaluation runs with `{other}`."
    ]


def test_another_config_is_named_with_what_differs_learning_fields_first(tmp_path):
    folder = str(committed_seeds(tmp_path, **{"agent.gamma": 0.9, "eval_every": 500,
                                              "decision_steps": 1, "recovery": "none"}))  # fmt: skip
    (note,) = policy_config_notes(method_runs(["dwa1", "d3dwa"], folder), "nav2", folder)
    assert note.startswith(
        f"`d3dwa` from `{folder}`: trained under its own config (`{folder}/seed-0/config.json`), "
        "not the committed `configs/d3dwa.yaml`: decision_steps 1 (committed 10), recovery none "
        "(committed nav2), agent.gamma 0.9 (committed 0.95), eval_every 500 (committed 2000)."
    )
    assert note.endswith(
        "It was trained with the recovery layer `none`; this evaluation runs with `nav2`."
    )
    # the same layer in evaluation: nothing to warn about
    (same,) = policy_config_notes(method_runs(["d3dwa"], folder), "none", folder)
    assert "this evaluation runs" not in same


def test_a_config_of_another_version_is_said_not_fatal(tmp_path):
    folder = committed_seeds(tmp_path, seeds=(0,))
    config = json.loads((folder / "seed-0" / "config.json").read_text())
    config["warp_drive"] = True  # a field this version does not know
    (folder / "seed-0" / "config.json").write_text(json.dumps(config))
    (note,) = policy_config_notes(method_runs(["d3dwa"], str(folder)), "none", str(folder))
    assert note.startswith(f"`d3dwa` from `{folder}`: its config could not be read")
    assert "warp_drive" in note


def test_a_folder_without_a_config_has_no_note(tmp_path):
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(8,)))
    path = save_checkpoint(tmp_path / "bare", agent, method="d3dwa")
    (path / "config.json").unlink(missing_ok=True)
    assert policy_config_notes(method_runs(["d3dwa"], str(path)), "none", str(path)) == []


@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_a_policy_of_another_config_runs_and_its_page_names_it(
    command, one_second_world, tmp_path, capsys
):
    folder = committed_seeds(tmp_path, seeds=(0,), **{"agent.lr": 0.0003})
    out = tmp_path / "out"
    extra = {"eval": [], "sweep": ["--styles", "", "--layouts", "0", "--axes", "",
                                   "--profiles", "none", "--workers", "1"]}[command]  # fmt: skip
    code, text, err = run(capsys, command, "--methods", "d3dwa", "--policy", folder, "--worlds",
                          one_second_world, "--seeds", "1", "--out", out, *extra)  # fmt: skip
    assert code == 0, err
    line = "agent.lr 0.0003 (committed 0.0001)."
    page = {"eval": "table.md", "sweep": "sweep.md"}[command]
    assert line in (out / page).read_text()
    if command == "eval":
        assert line in text
    (folder / "seed-0" / "learning_curve.png").write_bytes(PNG)
    code, _, err = run(capsys, "report", out)  # the page regenerated from meta.json says it too
    assert code == 0, err
    report = (out / "report.md").read_text()
    assert line in report
    # and it shows the curves of the policy it evaluated, not the shipped ones
    assert "figures/learning_curve_d3dwa_seed-0.png" in report
    assert f"(`{folder.name}/seed-0/learning_curve.png`)" in report and "dqdwa" not in report


@pytest.mark.parametrize(
    "changes",
    [{"eval_noise": "x" * 2**20}, {"worlds": ["TS1"] * 100_000}],
    ids=["unreadable", "readable"],
)
def test_a_megabyte_value_in_a_users_config_is_cut_and_marked(tmp_path, changes):
    folder = str(committed_seeds(tmp_path, **changes))
    (note,) = policy_config_notes(method_runs(["d3dwa"], folder), "nav2", folder)
    assert len(note) <= MAX_NOTE_CHARS.value + 40 and "[cut: " in note, note[:300]
    assert "\n" not in note
