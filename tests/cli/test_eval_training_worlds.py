"""``d3dwa eval`` of a policy trained on BARN worlds (issue 56): every page it writes names them,
and flags only the rows on a world the policy trained on; ``d3dwa report`` says the same from the
results directory; a policy without BARN training gets neither."""

from __future__ import annotations

import json
import shutil

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.training_worlds import MARK
from d3dwa_bullet.learning.training import TrainConfig
from d3dwa_bullet.world import barn
from d3dwa_bullet.world.barn_difficulty import barn_tercile
from tests.support.tiny_policy import tiny_run

IDS = TrainConfig(barn_split="train", barn_worlds=5).barn_ids
LINE = "`d3dwa` trained on 5 of BARN's 250 train worlds"


@pytest.fixture(scope="module")
def barn_policy(tmp_path_factory):
    """A 30-step policy trained on 5 of BARN's train worlds (IDS), shared by the tests."""
    return tiny_run(tmp_path_factory.mktemp("barn") / "run", barn_split="train", barn_worlds=5)


def _eval(policy, out, monkeypatch, capsys) -> str:
    monkeypatch.setattr(barn, "TIME_LIMIT", 2.0)  # short episodes: the test is about the pages
    argv = ["eval", "--suite", "barn", "--split", "all", "--world-ids", f"{IDS[0]},0",
            "--methods", "d3dwa", "--policy", str(policy), "--seeds", "1", "--workers", "1",
            "--out", str(out)]  # fmt: skip
    capsys.readouterr()
    assert main(argv) == 0
    return capsys.readouterr().out


def _d3dwa_cells(page: str) -> list[list[str]]:
    return [
        [c.strip() for c in line.split("|")[2:-1]]
        for line in page.splitlines()
        if line.startswith("| D3DWA |")
    ]


def test_eval_names_the_training_worlds_and_flags_only_the_trained_world(
    barn_policy, tmp_path, monkeypatch, capsys
):
    out = tmp_path / "eval"
    printed = _eval(barn_policy, out, monkeypatch, capsys)
    trained, challenge = f"BARN-{IDS[0]}", "BARN-0"
    table, seeds = (out / "table.md").read_text(), (out / "table_seeds.md").read_text()
    for page in (printed, table, seeds):
        words = " ".join(page.split())  # prose lines split to the page's width
        assert LINE in words and f"one of them ({trained})" in words
    success = next(c for c in _d3dwa_cells(table) if len(c) == 4)  # runs, the worlds, all
    assert success[1].endswith(MARK) and MARK not in success[2] + success[3]
    assert _d3dwa_cells(seeds)[0][1].endswith(MARK) and MARK not in _d3dwa_cells(seeds)[0][2]
    assert f"| barn-train {MARK} (1 of 1 trained on) |" in table
    assert "| D3DWA | barn-challenge |" in table
    settings = json.loads((out / "meta.json").read_text())["settings"]
    assert settings["barn_training"] == {"d3dwa": {"split": "train", "ids": list(IDS)}}
    assert main(["report", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert LINE in report and f"| barn-train {MARK} (1 of 1 trained on) |" in report
    assert challenge in report


def test_a_policy_without_barn_training_gets_no_line_and_no_mark(tmp_path, monkeypatch, capsys):
    policy = tiny_run(tmp_path / "run", generators=("R1-style",))
    out = tmp_path / "eval"
    printed = _eval(policy, out, monkeypatch, capsys)
    for page in (printed, (out / "table.md").read_text(), (out / "table_seeds.md").read_text()):
        assert MARK not in page and "trained on" not in page
    assert json.loads((out / "meta.json").read_text())["settings"]["barn_training"] == {}


def test_compare_names_the_training_worlds_and_flags_their_groups(
    barn_policy, tmp_path, monkeypatch, capsys
):
    learned, fixed = tmp_path / "learned", tmp_path / "fixed"
    _eval(barn_policy, learned, monkeypatch, capsys)
    argv = ["eval", "--suite", "barn", "--split", "all", "--world-ids", f"{IDS[0]},0",
            "--methods", "dwa3", "--workers", "1", "--out", str(fixed)]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    argv = ["compare", str(learned), "--against", str(fixed), "--methods", "d3dwa,dwa3"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    words = " ".join(printed.split())  # prose lines split to the page's width
    assert LINE in words and f"one of them (BARN-{IDS[0]})" in words
    groups = [ln.split("|")[1].strip() for ln in printed.splitlines() if "noise none" in ln]
    assert f"barn-{barn_tercile(IDS[0])}, noise none {MARK} (1 of 1 trained on)" in groups
    assert f"barn-{barn_tercile(0)}, noise none" in groups  # the challenge world's group: no mark
    assert main([*argv, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)["barn_training"]
    assert record == {"d3dwa": {"split": "train", "ids": list(IDS)}}


def test_sweep_and_its_report_name_the_training_worlds_and_flag_the_tercile(
    barn_policy, tmp_path, capsys
):
    out = tmp_path / "sweep"
    argv = ["sweep", "--suite", "barn", "--split", "all", "--world-ids", str(IDS[0]),
            "--methods", "d3dwa", "--policy", str(barn_policy), "--seeds", "1", "--axes", "",
            "--profiles", "none", "--time-limit", "2", "--workers", "1", "--out", str(out),
            "--json"]  # fmt: skip
    assert main(argv) == 0
    assert main(["report", str(out)]) == 0
    flagged = f"| barn-{barn_tercile(IDS[0])} {MARK} (1 of 1 trained on) |"
    for page in ((out / "sweep.md").read_text(), (out / "report.md").read_text()):
        assert LINE in page and flagged in page


def test_a_malformed_record_is_refused_in_one_line_before_any_episode(
    barn_policy, tmp_path, capsys
):
    policy = tmp_path / "policy"
    shutil.copytree(barn_policy, policy)
    meta = json.loads((policy / "meta.json").read_text())
    meta["metadata"]["barn"] = {"split": "train", "ids": [0]}  # a challenge world
    (policy / "meta.json").write_text(json.dumps(meta))
    out = tmp_path / "eval"
    argv = ["eval", "--suite", "barn", "--world-ids", "0", "--methods", "d3dwa",
            "--policy", str(policy), "--out", str(out)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("d3dwa: error: ")
    assert str(policy / "meta.json") in err and "metadata.barn.ids is [0]" in err
    assert not out.exists()
