"""tools.experiments.value_check: per-seed value calibration and seed agreement, bad input."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.learning.value_calibration import ValueCalibration
from d3dwa_bullet.resources import policies_dir
from tools.experiments import value_check


def test_a_directory_without_policies_is_one_line_and_status_2(tmp_path: Path, capsys) -> None:
    (tmp_path / "seed-0").mkdir()  # a seed folder without meta.json is no policy either
    assert value_check.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(tmp_path) in err[0] and "no policy" in err[0]


def test_two_seeds_get_a_calibration_each_and_an_agreement(tmp_path: Path, monkeypatch) -> None:
    for k in (0, 1):
        shutil.copytree(policies_dir() / "d3dwa" / f"seed-{k}", tmp_path / f"seed-{k}")
    result = value_check.check(tmp_path, worlds=("R1",))
    assert [s["policy"] for s in result["seeds"]] == ["seed-0", "seed-1"]
    for k, s in enumerate(result["seeds"]):
        config = load_train_config(tmp_path / f"seed-{k}" / "config.json")
        assert s["gamma"] == pytest.approx(config.agent.gamma) and s["pairs"] > 0
        assert s["mean_return"] <= 0.5 + 0.001 * s["pairs"]  # no episode earns more
        judged = ValueCalibration(s["mean_q"], s["mean_return"], s["pairs"], 1)
        assert s["calibrated"] is judged.calibrated  # the rule, on the figures it prints
        groups = s["by_outcome"]  # the one episode sits in the group of its outcome
        expected = "goal" if s["outcomes"]["R1"] == "goal" else "not goal"
        assert list(groups) == [expected] and groups[expected]["pairs"] == s["pairs"]
        assert groups[expected]["mean_q"] == pytest.approx(s["mean_q"])
        (episode,) = s["episodes_detail"]  # one world, one episode: its figures are the seed's
        assert episode["decisions"] == s["pairs"] and episode["world"] == "R1"
        assert episode["mean_return"] == pytest.approx(s["mean_return"])
    assert result["agreement_pairs"] == 1 and 0.0 <= result["agreement"] <= 1.0
    assert result["chance"] == pytest.approx(0.01)
    assert "does NOT" not in value_check.describe(result)  # the table says NO, not prose
    assert "| seed-1 |" in value_check.describe(result)
    assert "| seed-1 | 1 " in value_check.describe(result)  # the split by outcome
    assert "| seed-1 | R1 |" in value_check.describe_episodes(result)


def test_epsilon_outside_0_1_is_one_line_and_status_2(tmp_path: Path, capsys) -> None:
    assert value_check.main([str(tmp_path), "--epsilon", "1.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--epsilon" in err[0] and "1.5" in err[0]


@pytest.mark.parametrize("worlds", ["", " , ", "NOWHERE"])
def test_worlds_that_name_nothing_are_one_line_and_status_2(worlds: str, capsys) -> None:
    directory = str(policies_dir() / "d3dwa" / "seed-0")
    assert value_check.main([directory, "--worlds", worlds]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ("--worlds" in err[0] or "NOWHERE" in err[0]), err


def test_epsilon_greedy_explores_on_its_own_seeded_stream() -> None:
    obs = np.zeros(12)
    always_7 = value_check.epsilon_greedy(lambda o: 7, 100, 0.0, seed=0)
    assert {always_7(obs) for _ in range(50)} == {7}
    explore = [value_check.epsilon_greedy(lambda o: 7, 100, 0.5, seed=3) for _ in range(2)]
    runs = [[e(obs) for _ in range(200)] for e in explore]
    assert runs[0] == runs[1]  # the same seed, the same choices
    share = np.mean(np.array(runs[0]) != 7)
    assert 0.35 < share < 0.6  # about half explore (1 % of those draw 7 again)


def test_validation_reads_each_seeds_own_eval_worlds(tmp_path: Path) -> None:
    import json

    seed = tmp_path / "seed-0"
    shutil.copytree(policies_dir() / "d3dwa" / "seed-0", seed)
    config = json.loads((seed / "config.json").read_text())
    config["eval_worlds"] = ["TS2"]  # its validation, as its config says
    (seed / "config.json").write_text(json.dumps(config))
    result = value_check.check(tmp_path, worlds=(value_check.VALIDATION,))
    assert list(result["seeds"][0]["outcomes"]) == ["TS2"]


def _own_copy(tmp_path: Path, **config: object) -> Path:
    """A copy of a shipped policy whose config.json has ``config`` set."""
    import json

    seed = tmp_path / "seed-0"
    shutil.copytree(policies_dir() / "d3dwa" / "seed-0", seed)
    data = json.loads((seed / "config.json").read_text())
    (seed / "config.json").write_text(json.dumps({**data, **config}, indent=1))
    return seed


def test_a_config_cut_mid_way_is_one_line_without_a_caret(tmp_path: Path, capsys) -> None:
    """The parser's multi-line message (source line, caret) used to end the tool's output
    (issue 58, class 3): one line now, naming the file and where it stops."""
    seed = _own_copy(tmp_path)
    text = (seed / "config.json").read_text()
    (seed / "config.json").write_text(text[: len(text) // 2])
    assert value_check.main([str(seed)]) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and err.startswith("value_check: error: "), err
    assert str(seed / "config.json") in err and "line " in err and "^" not in err, err
    assert captured.out == ""


def test_validation_with_no_eval_worlds_refuses_before_any_progress(tmp_path: Path, capsys) -> None:
    """No 'N greedy episodes' line before the error: progress only once the run goes ahead."""
    seed = _own_copy(tmp_path, eval_worlds=[], eval_every=0)
    assert value_check.main([str(tmp_path), "--worlds", value_check.VALIDATION]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("value_check: error: "), err
    assert str(seed / "config.json") in err and "eval_worlds" in err, err


def test_validation_with_an_unknown_eval_world_refuses_before_any_progress(
    tmp_path: Path, capsys
) -> None:
    _own_copy(tmp_path, eval_worlds=["NOWHERE"])
    assert value_check.main([str(tmp_path), "--worlds", value_check.VALIDATION]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "NOWHERE" in err, err


def test_a_long_list_of_worlds_keeps_the_page_width() -> None:
    worlds = [f"BARN-{k}" for k in range(0, 60, 6)]
    result = {
        "directory": "policies/d3dwa-weights",
        "worlds": worlds,
        "seeds": [],
        "agreement": None,
    }
    text = value_check.describe(result)
    assert all(len(line) <= 120 for line in text.splitlines())
    assert " ".join(text.split()).startswith(
        f"policies/d3dwa-weights: greedy episodes on {', '.join(worlds)}"
    )
