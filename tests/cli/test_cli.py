"""The d3dwa command line, as a user calls it (in-process through cli.main)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest
import yaml

from d3dwa_bullet.cli.app import build_parser, main
from d3dwa_bullet.cli.options import parse_floats, split_list
from d3dwa_bullet.errors import ConfigError

TINY = {
    "name": "tiny",
    "group": "custom",
    "description": "a post between start and goal",
    "start": [0.0, 0.0, 0.0],
    "goal": [1.6, 0.0],
    "obstacles": [{"type": "cylinder", "center": [0.8, 0.35], "radius": 0.1}],
}


@pytest.fixture
def tiny_world(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return path


def test_worlds_lists_all_eleven(capsys):
    assert main(["worlds", "--json"]) == 0
    worlds = json.loads(capsys.readouterr().out)
    assert [w["name"] for w in worlds][:11] == [
        "TS1",
        "TS2",
        "TS3",
        "TS4",
        "US1",
        "H1",
        "H2",
        "H3",
        "R1",
        "R2",
        "R3",
    ]
    assert {w["group"] for w in worlds} == {"train", "unseen", "real"}


def test_run_json_has_the_documented_keys(tiny_world, capsys, tmp_path):
    png = tmp_path / "traj.png"
    assert (
        main(["run", "--world", str(tiny_world), "--method", "dwa3", "--json", "--plot", str(png)])
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    keys = {
        "world",
        "method",
        "seed",
        "outcome",
        "time_s",
        "tl_m",
        "pd_rad",
        "min_clearance_m",
        "steps",
    }
    assert keys <= set(out) and out["outcome"] == "goal" and out["world"] == "tiny"
    assert png.stat().st_size > 10_000


def test_run_with_start_goal_and_time_limit(capsys):
    args = [
        "run",
        "--world",
        "R1",
        "--method",
        "dwa2",
        "--start",
        "0.5,0,0",
        "--goal",
        "1.5,0.9",
        "--time-limit",
        "2",
        "--json",
    ]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["outcome"] == "timeout" and out["steps"] == 20


def test_eval_writes_results_table_and_figures(tiny_world, tmp_path, capsys):
    out = tmp_path / "res"
    args = [
        "eval",
        "--methods",
        "dwa3,random",
        "--worlds",
        str(tiny_world),
        "--seeds",
        "2",
        "--out",
        str(out),
        "--workers",
        "1",
    ]
    assert main(args) == 0
    text = capsys.readouterr().out
    with (out / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    # without noise DWA III repeats its episode: run once; the random chooser at each seed
    assert [(r["method"], r["seed"]) for r in rows] == [
        ("dwa3", "0"),
        ("random", "0"),
        ("random", "1"),
    ]
    table = (out / "table.md").read_text()
    assert "| DWA III (2,1,1) |" in table and "tiny Time" in table and table.strip() in text
    assert "Deterministic without noise: run once per layout" in table
    assert (out / "figures" / "tiny_time.png").exists()
    assert len(list((out / "logs").glob("*.npz"))) == 3
    # Running again resumes: nothing is recomputed, nothing is lost.
    assert main(args) == 0
    with (out / "results.csv").open() as fh:
        assert len(list(csv.DictReader(fh))) == 3


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "--world", "NOPE", "--method", "dwa1"], "unknown world 'NOPE'"),
        (["run", "--world", "TS1", "--method", "dwa9"], "unknown method 'dwa9'"),
        (["run", "--world", "TS1", "--method", "dwa1", "--goal", "1.5,0.3"], "--goal 1.5,0.3"),
        (["run", "--world", "TS1", "--method", "dwa1", "--start", "1,2"], "--start"),
        (["run", "--world", "TS1", "--method", "dwa1", "--noise", "bogus"], "bogus"),
        (["eval", "--methods", "dwa1", "--worlds", "TS1", "--seeds", "0"], "--seeds"),
        (
            [
                "run",
                "--world",
                "TS1",
                "--method",
                "dwa1",
                "--physics-hz",
                "240",
                "--control-hz",
                "7",
            ],
            "not divisible",
        ),
    ],
)
def test_bad_input_exits_2_with_one_line(args, message, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("d3dwa: error:") and message in err and "\n" not in err


def test_malformed_world_file_names_file_and_field(tmp_path, capsys):
    bad = dict(TINY, obstacles=[{"type": "box", "center": [1, 1], "size": [-0.2, 0.3]}])
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(bad))
    assert main(["run", "--world", str(path), "--method", "dwa1"]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "obstacles[0]" in err and "size" in err


HEAVY = ("pybullet", "torch", "matplotlib", "numba")


def heavy_modules_after(statement: str) -> list[str]:
    """The HEAVY modules a fresh interpreter holds after statement."""
    probe = f"import json, sys; {statement}; print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_help_and_worlds_start_without_the_simulator_torch_or_matplotlib():
    """What the commands' function-level imports are for: a quick `d3dwa --help` / `worlds`."""
    assert (
        heavy_modules_after("from d3dwa_bullet.cli.app import build_parser; build_parser()") == []
    )
    assert heavy_modules_after("from d3dwa_bullet.cli.app import main; main(['worlds'])") == []


def test_the_probe_sees_heavy_modules_when_a_command_loads_them():
    """The check above could fail: running an episode does bring pybullet in."""
    loaded = heavy_modules_after(
        "from d3dwa_bullet.cli.app import main; main(['run', '--world', 'R1', '--method', 'dwa1', "
        "'--time-limit', '0.2', '--json'])"
    )
    assert "pybullet" in loaded and "numba" in loaded


def test_every_command_is_wired_to_its_function():
    parser = build_parser()
    commands = {"worlds": [], "report": ["DIR"], "replay": ["b", "--out", "o"],
                "compare-scans": ["a", "b"], "record": ["--world", "R1", "--method", "dwa1", "--out", "o"],
                "run": ["--world", "R1", "--method", "dwa1"], "eval": [], "sweep": ["--out", "o"],
                "train": []}  # fmt: skip
    for name, rest in commands.items():
        func = parser.parse_args([name, *rest]).func
        expected = "cmd_compare" if name == "compare-scans" else f"cmd_{name}"
        assert func.__name__ == expected, name


def test_option_values_parse_or_name_the_option():
    assert parse_floats("1,2.5,-3", 3, "--start X,Y,YAW") == (1.0, 2.5, -3.0)
    assert split_list(" dwa1, ,dwa3,") == ["dwa1", "dwa3"]
    for bad in ("1,2", "1,x,3", ""):
        with pytest.raises(ConfigError, match=r"--start X,Y,YAW must be 3 comma-separated"):
            parse_floats(bad, 3, "--start X,Y,YAW")


def test_replay_refuses_a_malformed_goal_with_one_line(tmp_path, capsys):
    args = ["replay", str(tmp_path / "none.bag"), "--out", str(tmp_path / "o"), "--goal", "1"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err == "d3dwa: error: --goal must be 2 comma-separated numbers, got '1'"


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["eval", "--workers", "abc"], "d3dwa eval: error: argument --workers: invalid int value"),
        (["compare", "x", "--pair-by", "q"], "d3dwa compare: error: argument --pair-by"),
        (["bogus"], "d3dwa: error: argument command: invalid choice: 'bogus'"),
    ],
)
def test_an_option_argparse_refuses_is_one_line_without_the_usage(args, says, capsys):
    with pytest.raises(SystemExit) as done:
        main(args)
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(says) and err.count("\n") == 1 and "usage:" not in err
    assert err.rstrip().endswith("(--help lists the options)")
