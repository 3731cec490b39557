"""``d3dwa sweep --layout-seed S``: the unseen layouts are S, S+1, ... per style, S >= 2^31,
recorded in the settings (2^31 for a meta.json from before the option) and used wherever a
sweep names its layouts (its worlds, its page's titles, ``--reuse``'s named worlds)."""

from __future__ import annotations

import json
import re

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.reuse import _named_worlds
from d3dwa_bullet.evaluation.sweep import layout_titles, read_sweep, sweep_worlds
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from tests.support.cli import refused

BASE = UNSEEN_LAYOUT_SEED_BASE
ONE_STYLE = {"methods": ("dwa3",), "worlds": (), "styles": ("R1-style", "R3-style"), "layouts": 2}


def test_the_layouts_start_at_the_layout_seed():
    settings = SweepSettings(**ONE_STYLE, layout_seed=BASE + 10)
    names = [w.name for w, _ in sweep_worlds(settings)]
    assert names == [f"R{i}-style-s{BASE + k}" for i in (1, 3) for k in (10, 11)]
    assert layout_titles(settings)["generated"].endswith(
        f"(generator seeds {BASE + 10}..{BASE + 11})"
    )
    default = SweepSettings(**ONE_STYLE)
    assert default.layout_seed == BASE == 2**31
    assert [w.name for w, _ in sweep_worlds(default)][:2] == [
        "R1-style-s2147483648",
        "R1-style-s2147483649",
    ]


def test_an_older_meta_json_means_two_to_the_31():
    recorded = SweepSettings(**ONE_STYLE, layout_seed=BASE + 5).to_dict()
    assert recorded["layout_seed"] == BASE + 5
    assert SweepSettings.from_dict(recorded).layout_seed == BASE + 5
    older = {k: v for k, v in recorded.items() if k != "layout_seed"}
    assert SweepSettings.from_dict(older).layout_seed == BASE
    # --reuse proves a generated layout the same by its name: the names come from the seed
    assert _named_worlds({"kind": "sweep", **older}) == {
        f"R{i}-style-s{BASE + k}" for i in (1, 3) for k in (0, 1)
    }
    assert _named_worlds({"kind": "sweep", **recorded}) == {
        f"R{i}-style-s{BASE + k}" for i in (1, 3) for k in (5, 6)
    }


@pytest.mark.parametrize(
    ("seed", "says"),
    [
        (
            BASE - 1,
            f"--layout-seed {BASE - 1}: training draws generated layouts' seeds from [0, 2^31 = {BASE})",
        ),
        (0, "--layout-seed 0: training draws"),
        (
            2**63 - 1,
            f"--layout-seed {2**63 - 1}: with 2 layouts per style the last seed passes 2^63 - 1",
        ),
    ],
)
def test_a_seed_training_draws_from_is_refused(seed, says):
    with pytest.raises(ConfigError, match="^" + re.escape(says)):
        SweepSettings(**ONE_STYLE, layout_seed=seed)


def _sweep(out, *extra):
    return ["sweep", "--methods", "dwa3", "--worlds", "", "--styles", "R1-style", "--layouts", "1",
            "--axes", "", "--profiles", "none", "--seeds", "1", "--time-limit", "1", "--workers", "1",
            "--out", str(out), *extra]  # fmt: skip


def test_the_cli_records_it_refuses_below_and_a_resume_with_another(tmp_path, capsys):
    out = tmp_path / "sweep"
    line = refused(capsys, *_sweep(out, "--layout-seed", 12))
    assert line.startswith(
        "d3dwa: error: --layout-seed 12: training draws generated layouts' seeds from [0, 2^31"
    )
    assert not out.exists()
    line = refused(capsys, *_sweep(out, "--layout-seed", str(BASE), "--layouts", "0"))
    assert line.endswith(
        f"--layout-seed {BASE}: this sweep generates no layouts (--styles and --layouts choose them)"
    )
    assert not out.exists()
    assert main(_sweep(out, "--layout-seed", str(BASE + 3))) == 0
    capsys.readouterr()
    assert [r["world"] for r in read_sweep(out)] == [f"R1-style-s{BASE + 3}"]
    settings = json.loads((out / "meta.json").read_text())["settings"]
    assert settings["layout_seed"] == BASE + 3
    # the default, 2^31: other layouts than the rows'
    line = refused(capsys, *_sweep(out, "--json"))
    assert f"worlds R1-style-s{BASE + 3}" in line
    assert [r["world"] for r in read_sweep(out)] == [f"R1-style-s{BASE + 3}"]
