"""The `random` reference method through the commands: run, eval (a row of the default
tables), compare, sweep, record and replay; a policy given to it is refused in one line."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.cli.options import default_methods
from tests.support.cli import refused, run
from tools.experiments.failure_modes import failure_records
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.sim_bridge import make_step_fn, record_episode


def run_json(capsys, world: str, *extra: object) -> dict:
    code, out, err = run(capsys, "run", "--world", world, "--method", "random", "--json", *extra)
    assert code == 0, err
    return json.loads(out)


def test_run_random_is_the_same_episode_for_the_same_seed(one_second_world, tmp_path, capsys):
    a = run_json(capsys, one_second_world, "--seed", "3")
    assert a["method"] == "random" and a["steps"] == 10
    assert run_json(capsys, one_second_world, "--seed", "3") == a
    assert run_json(capsys, one_second_world, "--seed", "4") != a
    plot = tmp_path / "tau.png"
    code, text, _ = run(capsys, "run", "--world", one_second_world, "--method", "random",
                        "--plot", plot, "--colour-by", "tau")  # fmt: skip
    assert code == 0 and plot.stat().st_size > 10_000 and "policy:" not in text


@pytest.mark.parametrize("command", ["run", "record"])
def test_a_policy_for_random_is_refused(command, one_second_world, tmp_path, capsys):
    policy = tmp_path / "policy"
    policy.mkdir()
    out = ["--out", tmp_path / "bag"] if command == "record" else []
    line = refused(capsys, command, "--world", one_second_world, "--method", "random",
                   "--policy", policy, *out)  # fmt: skip
    assert f"--policy {policy}" in line and "'random'" in line and "needs no policy" in line
    assert not (tmp_path / "bag").exists()


def test_an_onnx_file_for_random_is_refused(one_second_world, tmp_path, capsys):
    line = refused(capsys, "run", "--world", one_second_world, "--method", "random",
                   "--onnx", tmp_path / "p.onnx")  # fmt: skip
    assert f"{tmp_path / 'p.onnx'}: method 'random' does not run a network" in line


@pytest.mark.parametrize("command", ["eval", "sweep"])
@pytest.mark.parametrize("method", ["random", "dwa2"])
def test_eval_and_sweep_refuse_a_policy_for_a_method_without_one(command, method, tmp_path,
                                                                 capsys):  # fmt: skip
    line = refused(capsys, command, "--methods", method, "--policy", tmp_path / "p",
                   "--out", tmp_path / "r")  # fmt: skip
    assert f"--policy {tmp_path / 'p'}: method {method!r}" in line
    assert not (tmp_path / "r").exists()


def test_export_says_random_has_no_policy(tmp_path, capsys):
    line = refused(capsys, "export", "--onnx", tmp_path / "out", "--method", "random")
    assert "--method random is a reference method: it has no policy to export" in line
    assert not (tmp_path / "out").exists()


def test_a_negative_seed_is_refused_naming_it(one_second_world, capsys):
    line = refused(capsys, "run", "--world", one_second_world, "--method", "random",
                   "--seed", "-1")  # fmt: skip
    assert "--seed" in line and "-1" in line  # refused by the CLI's seed check, before any episode


def test_the_default_methods_put_random_after_the_fixed_dwas():
    assert default_methods()[:5] == ["dwa1", "dwa2", "dwa3", "random", "random-weights"]


@pytest.fixture(scope="module")
def evaluated(one_second_world, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("random") / "res"
    code = run_main("eval", "--methods", "dwa1,random", "--worlds", one_second_world,
                    "--seeds", "3", "--workers", "1", "--out", out)  # fmt: skip
    assert code == 0
    return out


def run_main(*argv: object) -> int:
    from d3dwa_bullet.cli.app import main

    return main([str(a) for a in argv])


def test_eval_tables_figures_and_failure_modes_take_random(evaluated):
    with (evaluated / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    # without noise DWA I repeats its episode at every seed: run once; random at each seed
    assert [(r["method"], r["seed"]) for r in rows] == [("dwa1", "0")] + [
        ("random", str(s)) for s in range(3)
    ]
    table = (evaluated / "table.md").read_text()
    assert "| Random (uniform over 100 actions) | reference, 3 episodes |" in table
    assert "| DWA I (1,1,2) | fixed, 1 episode |" in table
    assert (evaluated / "figures" / "tiny_time.png").exists()
    records = {r["method"]: r for r in failure_records(evaluated)}
    assert records["random"]["episodes"] == 3


def test_compare_on_one_layout_says_why_there_is_no_paired_test(evaluated, capsys):
    capsys.readouterr()
    assert run_main("compare", evaluated, "--methods", "random,dwa1") == 0
    out = capsys.readouterr().out
    assert "### Success rate [%]" in out and "| Random (uniform over 100 actions) |" in out
    assert out.strip().splitlines()[-3:] == [
        "No paired test: methods 'random' and 'dwa1' share only one layout (tiny); a test "
        "paired by layout needs 2 or more.",
        "",
        "Reading: inconclusive (one shared layout cannot decide; see above).",
    ]


def test_sweep_takes_random(one_second_world, tmp_path, capsys):
    out = tmp_path / "sweep"
    code = run_main("sweep", "--methods", "random", "--worlds", one_second_world, "--styles", "",
                    "--layouts", "0", "--axes", "slip", "--levels", "1", "--profiles", "none",
                    "--seeds", "1", "--workers", "1", "--out", out)  # fmt: skip
    assert code == 0, capsys.readouterr().err
    assert "Random (uniform over 100 actions)" in (out / "sweep.md").read_text()


def test_a_recorded_random_episode_replays_its_actions_with_its_seed(one_second_world, tmp_path):
    results = []
    with BagRecorder(tmp_path / "bag") as rec:
        record_episode(one_second_world, "random", None, "none", 5, rec, on_result=results.append)
    actions = results[0].log["action"].astype(int).tolist()
    replay = replay_bag(tmp_path / "bag", make_step_fn("random", seed=5), plots=False)
    assert [r.action for r in replay.rows] == actions and len(actions) == 10
    assert np.array_equal([r.cmd for r in replay.rows], [r.recorded_cmd for r in replay.rows])
    other = replay_bag(tmp_path / "bag", make_step_fn("random", seed=6), plots=False)
    assert [r.action for r in other.rows] != actions


def test_replay_seed_option_reaches_the_random_method(one_second_world, tmp_path, capsys):
    with BagRecorder(tmp_path / "bag") as rec:
        record_episode(one_second_world, "random", None, "none", 5, rec)
    for seed in ("5", "6"):
        code, _, err = run(capsys, "replay", tmp_path / "bag", "--method", "random",
                           "--seed", seed, "--out", tmp_path / seed, "--no-plots")  # fmt: skip
        assert code == 0, err
    with (tmp_path / "5" / "replay.csv").open() as fh:
        five = [r["action"] for r in csv.DictReader(fh)]
    with (tmp_path / "6" / "replay.csv").open() as fh:
        six = [r["action"] for r in csv.DictReader(fh)]
    assert len(five) == 10 and five != six
