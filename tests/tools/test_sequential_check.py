"""tools/experiments/sequential_check: the simulation figures, and bad input in one line."""

from __future__ import annotations

import json

import pytest

from tools.experiments.sequential_check import main


def test_prints_the_figures_as_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(
            [
                "--looks",
                "3",
                "--replicates",
                "2000",
                "--layouts",
                "60",
                "--paths",
                "200000",
                "--json",
            ]
        )
        == 0
    )
    (r,) = json.loads(capsys.readouterr().out)
    assert r["looks"] == 3 and r["replicates"] == 2000
    for key in ("difference_when_none", "equivalent_on_upper_margin", "power"):
        assert r[key]["low"] <= r[key]["rate"] <= r[key]["high"]
    assert r["difference_when_none"]["low"] < 0.05 and r["power"]["high"] > 0.8
    level = r[
        "difference_level"
    ]  # the finer figure: the t's bounds hold 5 %, the normal ones read more often
    assert (
        level["t"]["low"] < 0.05 < level["t"]["high"]
        and level["normal"]["rate"] > level["t"]["rate"]
    )


@pytest.mark.parametrize(
    ("argv", "says"),
    [(["--looks", "x"], "--looks must be a comma list"), (["--looks", "0"], "between 1 and 50"),
     (["--replicates", "5"], "--replicates in 100..1000000"), (["--margin", "-1"], "must be in (0, 5) sd"),
     (["--paths", "10"], "--paths must be in 1000..20000000")],
)  # fmt: skip
def test_bad_input(argv: list[str], says: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
