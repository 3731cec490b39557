"""tools/experiments/multiplicity_check: the figures of each case and rule, and bad input in one line."""

from __future__ import annotations

import json

import pytest

from tools.experiments.multiplicity_check import main


def test_prints_each_case_and_rule_as_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--replicates", "1000", "--paths", "100000", "--naive", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    got = {(r["case"], r["rule"]): r for r in out}
    assert len(got) == 8 and {r["replicates"] for r in out} == {1000}
    for r in out:
        assert r["low"] <= r["familywise_false_read"] <= r["high"]
    # four ties: nothing can pass a level, so Holm is Bonferroni on the same draws
    assert (
        got[("ties", "holm")]["familywise_false_read"]
        == got[("ties", "bonferroni")]["familywise_false_read"]
    )
    assert got[("mixed", "holm")]["true_reads"] >= got[("mixed", "bonferroni")]["true_reads"]
    assert got[("ties", "none")]["familywise_false_read"] > got[("ties", "bonferroni")]["high"]


@pytest.mark.parametrize(
    ("argv", "says"),
    [(["--replicates", "5"], "--replicates must be in 100..200000, got 5"),
     (["--paths", "10"], "--paths must be in 10000..20000000, got 10"), (["--seed", "-1"], "--seed must be >= 0")],
)  # fmt: skip
def test_bad_input(argv: list[str], says: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
