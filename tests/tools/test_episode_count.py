"""tools/bench/episode_count: the episodes of an eval or sweep command, counted without one
running, before and since a deterministic episode runs once per layout."""

from __future__ import annotations

import json

from tools.bench.episode_count import main


def test_counts_the_listed_and_the_run_episodes_of_an_eval_and_a_sweep(one_second_world, capsys):
    argv = ["eval", "--methods", "dwa1,random", "--worlds", one_second_world, "--seeds", "3"]
    assert main(argv) == 0
    counted = json.loads(capsys.readouterr().out)
    assert (counted["listed"], counted["run"], counted["saved"]) == (6, 4, 2)
    assert counted["by_method"] == {"dwa1": [3, 1], "random": [3, 3]}
    sweep = ["sweep", "--methods", "dwa3", "--worlds", one_second_world, "--styles", "",
             "--layouts", "0", "--axes", "slip", "--levels", "2", "--profiles", "none,real",
             "--seeds", "2"]  # fmt: skip
    assert main(sweep) == 0
    counted = json.loads(capsys.readouterr().out)
    # baseline (none) + 2 slip levels + real, 2 seeds each; the baseline's second seed is saved
    assert (counted["listed"], counted["run"]) == (8, 7)


def test_refuses_another_command_and_an_out_in_one_line(capsys):
    assert main(["train", "--config", "x.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("episode_count: error: argument command: invalid choice: 'train'")
    assert main(["eval", "--out", "somewhere"]) == 2
    assert "leave out --out" in capsys.readouterr().err
