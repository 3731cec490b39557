"""`d3dwa compare`'s readings flag the groups holding a side's BARN training worlds (issue 56),
as its P(A > B) table does: hand-made results directories, no episode run."""

from __future__ import annotations

import json

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.page_width import PAGE_WIDTH
from d3dwa_bullet.evaluation.training_worlds import MARK
from d3dwa_bullet.learning.training import TrainConfig
from d3dwa_bullet.world.barn_difficulty import barn_tercile
from tests.support.results_logs import write_results

IDS = TrainConfig(barn_split="train", barn_worlds=5).barn_ids
TRAINED = IDS[0]
"""A world the BARN-trained policy trained on."""
CHALLENGE = 0
"""A challenge world: never trained on."""
OTHER = next(i for i in range(1, 300) if i not in IDS and barn_tercile(i) == barn_tercile(TRAINED))
"""A world in TRAINED's tercile the policy did not train on."""


def _results(path, training):
    """A results directory (eval's columns) of d3dwa (one policy) and dwa3 on TRAINED, OTHER and
    CHALLENGE under noise `real`, two evaluation seeds each; meta.json keeps ``training`` as
    ``settings.barn_training``."""
    rows = []
    for k, i in enumerate((TRAINED, OTHER, CHALLENGE)):
        for s in (0, 1):
            for m, mod in (("d3dwa", 3), ("dwa3", 2)):
                rows.append(dict(world=f"BARN-{i}", method=m, policy_seed="", seed=s,
                                 noise="real", outcome="goal" if (k + s) % mod else "timeout",
                                 time_s=5.0 + k))  # fmt: skip
    write_results(path, ((r, {}) for r in rows), sweep=False)
    meta = {"format": 3, "settings": {"barn_training": training}, "jobs": []}
    (path / "meta.json").write_text(json.dumps(meta))
    return path


def _readings_rows(printed: str) -> dict[str, str]:
    """The readings table's first part: group (its first cell) -> its 'trained on' cell ('' when
    the table has no such column); every part of a split table keeps the same groups."""
    part = (
        printed.split("Readings about these policies")[1]
        .split("\n\nReadings about the recipe")[0]
        .split("\n\n| tasks")[1]
    )
    header, _, *body = part.strip().splitlines()
    column = [c.strip() for c in header.split("|")[1:-1]][1] == "trained on"
    rows = {}
    for line in body:
        cells = [c.strip() for c in line.split("|")[1:-1]]
        rows[cells[0]] = cells[2] if column else ""
    for other in (
        printed.split("Readings about these policies")[1]
        .split("\n\nReadings about the recipe")[0]
        .split("\n\n| tasks")[2:]
    ):
        assert {ln.split(" | ")[0][2:] for ln in other.strip().splitlines()[2:]} == set(rows)
    return rows


def test_the_readings_flag_the_group_with_a_training_world_and_not_the_challenge_one(
    tmp_path, capsys
):
    record = {"split": "train", "ids": list(IDS)}
    out = _results(tmp_path / "eval", {"d3dwa": record})
    argv = ["compare", str(out), "--methods", "d3dwa,dwa3"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert all(len(line) <= PAGE_WIDTH for line in printed.splitlines())
    assert barn_tercile(CHALLENGE) != barn_tercile(TRAINED)
    trained, challenge = (f"barn-{barn_tercile(i)}, noise real" for i in (TRAINED, CHALLENGE))
    assert _readings_rows(printed) == {
        f"{trained} {MARK}": "1 of 2",
        challenge: "",
        f"all {MARK}": "1 of 3",
    }
    assert main([*argv, "--json"]) == 0
    groups = {g["group"]: g for g in json.loads(capsys.readouterr().out)["groups"]}
    assert groups[trained]["trained_on"] == {"d3dwa": {"trained": 1, "worlds": 2}}
    assert groups[challenge]["trained_on"] == {} and "readings" in groups[challenge]
    assert groups["all"]["trained_on"] == {"d3dwa": {"trained": 1, "worlds": 3}}


def test_without_barn_training_no_readings_row_is_flagged(tmp_path, capsys):
    out = _results(tmp_path / "eval", {})
    assert main(["compare", str(out), "--methods", "d3dwa,dwa3"]) == 0
    printed = capsys.readouterr().out
    assert MARK not in printed and "trained on" not in printed
    groups = {f"barn-{barn_tercile(i)}, noise real" for i in (TRAINED, CHALLENGE)} | {"all"}
    assert _readings_rows(printed) == dict.fromkeys(groups, "")


def test_when_both_sides_trained_each_count_says_whose_worlds(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # short directories: each side's label names its own
    _results(tmp_path / "a", {"d3dwa": {"split": "train", "ids": list(IDS)}})
    _results(tmp_path / "b", {"d3dwa": {"split": "train", "ids": [OTHER]}})
    argv = ["compare", "a", "--against", "b", "--methods", "d3dwa,d3dwa"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert all(len(line) <= PAGE_WIDTH for line in printed.splitlines())
    trained = f"barn-{barn_tercile(TRAINED)}, noise real"
    both = f"{MARK} (A: 1 of 2 trained on) {MARK} (B: 1 of 2 trained on)"
    assert f"| {trained} {both} |" in printed  # the P(A > B) table
    assert _readings_rows(printed) == {
        f"{trained} {MARK}": "A: 1 of 2, B: 1 of 2",
        f"barn-{barn_tercile(CHALLENGE)}, noise real": "",
        f"all {MARK}": "A: 1 of 3, B: 1 of 3",
    }
    assert main([*argv, "--json"]) == 0
    groups = {g["group"]: g for g in json.loads(capsys.readouterr().out)["groups"]}
    assert groups[trained]["trained_on"] == {
        "d3dwa [A]": {"trained": 1, "worlds": 2},
        "d3dwa [B]": {"trained": 1, "worlds": 2},
    }
