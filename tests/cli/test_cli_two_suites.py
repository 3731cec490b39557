"""``--suite barn,barn-style``: BARN's worlds and fresh BARN-style worlds in one run (issue 79's
BARN-style family), each row in its layout group, so a plan reads ``barn`` and ``barn-style``
as two strata of one family."""

from __future__ import annotations

import argparse

import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.cli.suites import suite_world_names
from d3dwa_bullet.evaluation.plans.order import stratum_of
from d3dwa_bullet.evaluation.sweep import read_sweep
from tests.cli.test_sweep_plan import PLAN
from tests.support.cli import refused

FIRST = 2**31


def _names(**given) -> list[str] | None:
    options = ("suite", "worlds", "split", "world_ids", "count", "world_seed")
    return suite_world_names(argparse.Namespace(**({k: None for k in options} | given)))


def test_both_suites_name_barns_worlds_then_fresh_ones():
    both = _names(suite="barn,barn-style", world_ids="0,6", count="2", world_seed=str(FIRST + 4))
    assert both == ["BARN-0", "BARN-6", f"BARN-style-s{FIRST + 4}", f"BARN-style-s{FIRST + 5}"]
    swapped = _names(
        suite="barn-style, barn", world_ids="0,6", count="2", world_seed=str(FIRST + 4)
    )
    assert swapped == both[2:] + both[:2]  # the order given
    assert _names(suite="barn", split="challenge") == _names(suite="barn,", split="challenge")
    assert (
        len(_names(suite="barn,barn-style", count="3")) == 50 + 3
    )  # the challenge split by default


def _sweep(out, *extra):
    return ["sweep", "--suite", "barn,barn-style", "--world-ids", "0,6", "--count", "2",
            "--methods", "dwa1,dwa3", "--axes", "", "--profiles", "none", "--seeds", "1",
            "--time-limit", "1", "--workers", "1", "--out", str(out), *extra]  # fmt: skip


def test_one_sweep_holds_both_strata_and_a_plan_reads_them(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert main(_sweep(out)) == 0
    rows = read_sweep(out)
    strata = {(r["world"], r["layout"], stratum_of(r)) for r in rows}
    assert strata == {
        ("BARN-0", "barn-easy", "barn"),
        ("BARN-6", "barn-middle", "barn"),
        (f"BARN-style-s{FIRST}", "barn-style", "barn-style"),
        (f"BARN-style-s{FIRST + 1}", "barn-style", "barn-style"),
    }
    page = (out / "sweep.md").read_text()
    assert "BARN easy tercile: BARN-0" in page and "BARN-style worlds (not BARN's)" in page
    # a plan whose family is both strata: its first look takes two of each (the order interleaves)
    family = {"barn-style": {"strata": ["barn", "barn-style"], "looks": [4], "maximum": 4}}
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump(PLAN | {"families": family}))
    capsys.readouterr()
    assert main(_sweep(tmp_path / "plan", "--plan", str(plan))) == 0
    assert "barn-style: dwa1 vs dwa3 under none:" in capsys.readouterr().out
    assert {stratum_of(r) for r in read_sweep(tmp_path / "plan")} == {"barn", "barn-style"}


@pytest.mark.parametrize(
    ("suite", "extra", "says"),
    [
        ("barn,nope", [], "--suite: unknown suite 'nope'; choose from barn, barn-style (or both: "),
        ("barn,barn", [], "--suite barn,barn: names a suite twice"),
        (",", [], "--suite is empty"),
        ("barn,barn-style", [], "--suite barn-style needs --count"),
        (
            "barn-style",
            ["--count", "2", "--world-ids", "0"],
            "--world-ids does not apply to --suite barn-style",
        ),
        ("barn", ["--count", "2"], "--count does not apply to --suite barn"),
    ],
)
@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_bad_suites_are_one_line(command, suite, extra, says, tmp_path, capsys):
    out = tmp_path / "never"
    line = refused(capsys, command, "--suite", suite, *extra, "--methods", "dwa3", "--out", out)
    assert says in line
    assert not out.exists()


def test_worlds_lists_one_suite_at_a_time(capsys):
    line = refused(capsys, "worlds", "--suite", "barn,barn-style", "--count", "2")
    assert line == "d3dwa: error: worlds --suite barn,barn-style: list one suite at a time"
