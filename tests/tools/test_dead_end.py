"""tools.experiments.dead_end: branches from one greedy state, bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from tools.experiments import dead_end

PILOT = Path(__file__).resolve().parents[2] / "docs" / "pilots" / "d3dwa-dp-b" / "seed-2"


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--world", "R2", "--at", "-1"], "--at"),
        (["--world", "R2", "--at", "2", "--actions", "x"], "--actions"),
        (["--world", "R2", "--at", "2", "--actions", "100"], "100"),
        (["--world", "R2", "--at", "500"], "--at 500"),
    ],
)
def test_bad_input_is_one_line_and_status_2(args: list[str], named: str, capsys) -> None:
    assert dead_end.main([str(PILOT), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and named in err[0]


def test_a_branch_that_moves_is_told_from_the_stall(tmp_path: Path) -> None:
    # from the start of R2 (decision 0) the robot can drive: a held action moves it, and the
    # branches replay one identical start, so one action's branch is the same every time
    result = dead_end.branches(PILOT, "R2", at=0, hold=2, then=0, actions=[8, 8, 40])
    a, b, c = result["branches"]
    assert a == b and a["action"] == 8 and c["action"] == 40
    assert result["moved"] >= 1 and all(r["outcome"] == "running" for r in result["branches"])
    assert result["goal_distance_m"] > 1.0 and a["q"] == pytest.approx(b["q"])
