"""What a new or careless user trips on, and what the CLI does about it (issue 13).

Every refusal is exit status 2 and exactly one stderr line ``d3dwa: error: ...`` naming the
option, file, field or value at fault, and it comes before any work that could be lost:
nothing the user made is damaged, no stray temporary file is left, and a results table
never disagrees with its results.csv. Episodes here are one second or less on tiny worlds.

The tests run as root, for whom permission bits do not stop a write. An unwritable place
is therefore simulated in ways that hold for root too: a path *under an existing file*
(``file/sub``: no one can create it), a path under /proc, or ``os.access`` monkeypatched
to answer "no" for the directory (the check the CLI makes before it starts).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch
import yaml

import d3dwa_bullet.episode as episode_module
from d3dwa_bullet.cli.app import build_parser, main
from d3dwa_bullet.cli.output import json_text, strict
from d3dwa_bullet.sim.scan import LaserScan
from tests.conftest import ONE_SECOND_WORLD
from tests.support.bag_messages import scan_msg
from tests.support.cli import refused, run
from transfer import sim_bridge
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.topics import LASER_SCAN, TopicMap

MS = 1_000_000
TINY = ONE_SECOND_WORLD
MESH_ONLY_SDF = """<?xml version="1.0"?>
<sdf version="1.7"><world name="w">
  <include><uri>model://ground_plane</uri></include>
  <model name="chair"><link name="l"><collision name="c">
    <geometry><mesh><uri>chair.dae</uri></mesh></geometry>
  </collision></link></model>
</world></sdf>
"""


def strict_json(text: str):
    """json.loads that fails on NaN / Infinity, which Python's json would accept."""

    def refuse(name: str):
        raise AssertionError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def files_in(directory: Path) -> set[str]:
    return {str(p.relative_to(directory)) for p in directory.rglob("*")}


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return path


@pytest.fixture
def deny_write(monkeypatch: pytest.MonkeyPatch):
    """Make os.access say "no write permission" for the given directories (as chmod would
    for a non-root user; root ignores permission bits, so the tests cannot rely on them)."""
    denied: list[Path] = []
    real = os.access

    def access(path, mode, *args, **kwargs):
        if mode & os.W_OK and Path(path).resolve() in denied:
            return False
        return real(path, mode, *args, **kwargs)

    monkeypatch.setattr(os, "access", access)
    return lambda *paths: denied.extend(Path(p).resolve() for p in paths)


# 1. Negative coordinates ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "dest", "value"),
    [
        (["run", "--world", "R1", "--method", "dwa1", "--start", "-1,2,0"], "start", "-1,2,0"),
        (["run", "--world", "R1", "--method", "dwa1", "--goal", "-2.5,1.3"], "goal", "-2.5,1.3"),
        (["run", "--world", "R1", "--method", "dwa1", "--start=-1,2,0"], "start", "-1,2,0"),
        (["run", "--world", "R1", "--method", "dwa1", "--goal", "-.5,-1e-1"], "goal", "-.5,-1e-1"),
        (["replay", "b", "--out", "o", "--goal", "-2.5,1.3"], "goal", "-2.5,1.3"),
        (["replay", "b", "--out", "o", "--mount", "-0.1,0,-3.1"], "mount", "-0.1,0,-3.1"),
        (["replay", "b", "--mount=-0.1,0,0", "--out", "o"], "mount", "-0.1,0,0"),
    ],
)
def test_negative_coordinates_are_values_not_options(argv, dest, value):
    assert getattr(build_parser().parse_args(argv), dest) == value


def test_an_option_name_after_a_coordinate_option_is_still_an_option(capsys):
    with pytest.raises(SystemExit) as stop:  # argparse's own error: --start lacks its value
        build_parser().parse_args(["run", "--world", "R1", "--method", "dwa1", "--start", "--json"])
    assert stop.value.code == 2 and "--start: expected one argument" in capsys.readouterr().err


def test_run_with_a_negative_start_and_goal(tiny, capsys):
    code, out, err = run(
        capsys, "run", "--world", tiny, "--method", "dwa3", "--start", "-0.5,0,0",
        "--goal", "-1.5,-0.2", "--time-limit", "0.5", "--json",
    )  # fmt: skip
    assert code == 0, err
    summary = strict_json(out)
    assert summary["outcome"] == "timeout" and summary["steps"] == 5


def write_scan_bag(path: Path, scans: list[list[float]], odometry: bool = True) -> Path:
    """Scans k = 1, 2, ... at k * 100 ms (robot at rest), odometry over the same span."""
    with BagRecorder(path, goal=(2.0, 0.0)) as rec:
        if odometry:
            for k in range(1, len(scans) + 2):
                rec.write_odometry(k * 100 * MS, (0.0, 0.0, 0.0), (0.0, 0.0))
        for k, ranges in enumerate(scans, start=1):
            rec.write_message(
                TopicMap().scan, LASER_SCAN, k * 100 * MS, scan_msg(rec, k * 100 * MS, ranges)
            )
    return path


def test_replay_takes_a_negative_goal_and_mount(tmp_path, capsys):
    bag = write_scan_bag(tmp_path / "bag", [[1.0] * 21] * 3)
    code, out, err = run(
        capsys, "replay", bag, "--goal", "-2.5,1.3", "--mount", "-0.1,0,0",
        "--out", tmp_path / "o", "--no-plots", "--json",
    )  # fmt: skip
    assert code == 0, err
    summary = strict_json(out)
    assert summary["goal"] == [-2.5, 1.3] and summary["mount"]["x"] == -0.1
    assert summary["replayed"] == 3


# 2. Files of binary garbage ---------------------------------------------------------------

GARBAGE = bytes(range(256)) * 4


@pytest.mark.parametrize("name", ["world.yaml", "world.yml", "world.world", "world.sdf"])
def test_a_world_file_of_binary_garbage_is_one_line_naming_it(tmp_path, capsys, name):
    path = tmp_path / name
    path.write_bytes(GARBAGE)
    line = refused(capsys, "run", "--world", path, "--method", "dwa1")
    assert str(path) in line and "Traceback" not in line


def test_other_files_of_binary_garbage(tmp_path, capsys, tiny):
    profile = tmp_path / "noise.yaml"
    profile.write_bytes(GARBAGE)
    line = refused(capsys, "run", "--world", tiny, "--method", "dwa1", "--noise", profile)
    assert f"{profile}: not a text profile YAML" in line
    results = tmp_path / "res"
    results.mkdir()
    (results / "meta.json").write_bytes(GARBAGE)
    assert f"{results / 'meta.json'}: not a text" in refused(capsys, "report", results)


# 3. eval --out that cannot be written ---------------------------------------------------


def eval_args(world: Path, out: Path, *more: object) -> list[object]:
    return ["eval", "--methods", "dwa1", "--worlds", world, "--workers", "1", "--out", out, *more]


@pytest.fixture
def no_episode(monkeypatch):
    """Any episode that runs fails the test: refusals must come before the first one."""

    def forbidden(*args, **kwargs):
        raise AssertionError("an episode ran before the refusal")

    monkeypatch.setattr(episode_module, "run_episode", forbidden)
    monkeypatch.setattr("d3dwa_bullet.evaluation.jobs.run_episode", forbidden)


def test_eval_out_naming_an_existing_file(tmp_path, capsys, tiny, no_episode):
    target = tmp_path / "afile"
    target.write_text("mine")
    line = refused(capsys, *eval_args(tiny, target))
    assert f"--out {target}: exists and is not a directory" in line
    assert target.read_text() == "mine"


def test_eval_out_under_a_file(tmp_path, capsys, tiny, no_episode):
    """A path under an existing file cannot be created, even by root."""
    (tmp_path / "afile").write_text("mine")
    line = refused(capsys, *eval_args(tiny, tmp_path / "afile" / "sub"))
    assert "--out" in line and f"{tmp_path / 'afile'} is a file, not a directory" in line


def test_eval_out_where_nothing_can_be_created(capsys, tiny, no_episode):
    """/proc takes no new directories, whoever asks."""
    line = refused(capsys, *eval_args(tiny, Path("/proc/d3dwa-results")))
    assert "--out /proc/d3dwa-results: cannot create" in line


def test_eval_out_in_a_read_only_directory(tmp_path, capsys, tiny, no_episode, deny_write):
    """os.access monkeypatched: read-only as a non-root user would see it."""
    deny_write(tmp_path / "ro")
    (tmp_path / "ro").mkdir()
    line = refused(capsys, *eval_args(tiny, tmp_path / "ro"))
    assert f"--out {tmp_path / 'ro'}: cannot write in" in line and "permission denied" in line
    assert files_in(tmp_path / "ro") == set()


def test_eval_out_whose_figures_entry_is_a_file(tmp_path, capsys, tiny, no_episode):
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "figures").write_text("mine")
    line = refused(capsys, *eval_args(tiny, tmp_path / "res"))
    assert "figures exists and is not a directory" in line


def test_replay_out_naming_an_existing_file(tmp_path, capsys):
    bag = write_scan_bag(tmp_path / "bag", [[1.0] * 21])
    (tmp_path / "afile").write_text("mine")
    line = refused(capsys, "replay", bag, "--out", tmp_path / "afile")
    assert f"--out {tmp_path / 'afile'}: exists and is not a directory" in line


def test_report_into_a_read_only_directory(tmp_path, capsys, tiny, deny_write):
    out = tmp_path / "res"
    assert main([str(a) for a in eval_args(tiny, out)]) == 0
    capsys.readouterr()
    deny_write(out)
    line = refused(capsys, "report", out)
    assert f"{out}: cannot write report.md" in line and not (out / "report.md").exists()


# 4. run --plot ----------------------------------------------------------------------------


def run_args(world: Path, *more: object) -> list[object]:
    return ["run", "--world", world, "--method", "dwa3", "--time-limit", "0.5", *more]


@pytest.mark.parametrize(
    ("where", "message"),
    [
        ("adir", "is a directory; give a file name"),
        ("afile/x.png", "is a file, not a directory"),
        ("fig.xyz", "unknown file type '.xyz'"),
    ],
)
def test_run_plot_is_checked_before_the_episode(tmp_path, capsys, tiny, no_episode, where, message):
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("mine")
    before = files_in(tmp_path)
    line = refused(capsys, *run_args(tiny, "--plot", tmp_path / where))
    assert f"--plot {tmp_path / where}" in line and message in line
    assert files_in(tmp_path) == before


def test_run_plot_into_a_read_only_directory(tmp_path, capsys, tiny, no_episode, deny_write):
    (tmp_path / "ro").mkdir()
    deny_write(tmp_path / "ro")
    line = refused(capsys, *run_args(tiny, "--plot", tmp_path / "ro" / "t.png"))
    assert "--plot" in line and "permission denied" in line


def test_a_figure_that_fails_after_the_episode_keeps_the_json(tmp_path, capsys, tiny, monkeypatch):
    """The location passed the check, then the write failed: the summary is out already,
    and the atomic write leaves no temporary file."""
    real_replace = os.replace

    def failing_replace(src, dst, *args, **kwargs):
        if str(dst).endswith(".png"):
            raise PermissionError(13, "Permission denied")
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", failing_replace)
    code, out, err = run(capsys, *run_args(tiny, "--plot", tmp_path / "t.png", "--json"))
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("d3dwa: error: --plot ")
    assert "summary is printed above" in lines[0]
    assert strict_json(out)["steps"] == 5
    assert files_in(tmp_path) == {"tiny.yaml"}  # no t.png, no .t.png.*.tmp


# 5. and 9. --time-limit, --start, --goal: the option is named, zero is refused ------------


@pytest.mark.parametrize("value", ["0", "-5", "nan", "inf", "-0"])
def test_a_time_limit_that_is_not_positive_and_finite_is_refused(tmp_path, capsys, tiny, value):
    line = refused(capsys, "run", "--world", tiny, "--method", "dwa1", "--time-limit", value)
    assert line.startswith("d3dwa: error: --time-limit must be") and "tiny.yaml" not in line
    line = refused(
        capsys, "sweep", "--methods", "dwa1", "--out", tmp_path / "sw", "--time-limit", value
    )
    assert "--time-limit" in line and not (tmp_path / "sw").exists()
    line = refused(capsys, "record", "--world", tiny, "--method", "dwa1", "--out",
                   tmp_path / "bag", "--time-limit", value)  # fmt: skip
    assert "--time-limit" in line and not (tmp_path / "bag").exists()


@pytest.mark.parametrize("seed", ["-1", str(2**32)])
@pytest.mark.parametrize(
    "argv",
    [
        ["serve", "--world", "R1", "--noise", "real", "--port", "0"],
        ["run", "--world", "R1", "--method", "dwa1", "--noise", "real"],
        ["record", "--world", "R1", "--method", "dwa1", "--noise", "real", "--out", "BAG"],
        ["eval", "--worlds", "R1", "--methods", "dwa1", "--noise", "real", "--out", "OUT"],
        ["sweep", "--methods", "dwa1", "--out", "OUT"],
    ],
    ids=lambda argv: argv[0],
)
def test_a_seed_numpy_cannot_take_is_one_line(tmp_path, capsys, no_episode, argv, seed):
    """A negative --seed ended numpy's seeding of the noise in a traceback."""
    paths = {"BAG": str(tmp_path / "bag"), "OUT": str(tmp_path / "out")}
    line = refused(capsys, *(paths.get(a, a) for a in argv), "--seed", seed)
    assert line.startswith("d3dwa: error: --seed") and seed in line
    assert not (tmp_path / "bag").exists() and not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--goal", "0.8,0.35", "--goal 0.8,0.35 lies inside an obstacle of"),
        ("--start", "0.8,0.3,0", "--start 0.8,0.3,0 puts the robot body in collision"),
        ("--goal", "nan,1", "--goal X,Y must be 2 finite numbers"),
        ("--start", "-1,inf,0", "--start X,Y,YAW must be 3 finite numbers"),
    ],
)
def test_task_options_name_the_option_not_the_file(capsys, tiny, option, value, message):
    line = refused(capsys, "run", "--world", tiny, "--method", "dwa1", option, value)
    assert message in line and "field '" not in line


def test_a_world_file_task_error_still_names_the_file(tmp_path, capsys):
    bad = dict(TINY, goal=[0.8, 0.35])
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(bad))
    line = refused(capsys, "run", "--world", path, "--method", "dwa1")
    assert f"{path}: field 'goal'" in line


# 6. eval into a directory holding another evaluation -------------------------------------


def table_methods(out: Path) -> set[str]:
    return {line.split("|")[1].strip() for line in (out / "table.md").read_text().splitlines()
            if line.startswith(("| DWA", "| Random"))}  # fmt: skip


def csv_keys(out: Path) -> set[tuple[str, str, str]]:
    with (out / "results.csv").open() as fh:
        return {(r["world"], r["method"], r["seed"]) for r in csv.DictReader(fh)}


def test_eval_never_writes_a_table_that_disagrees_with_its_csv(tmp_path, capsys, tiny):
    out = tmp_path / "res"
    base = ["eval", "--worlds", tiny, "--workers", "1", "--out", out]
    assert main([str(a) for a in [*base, "--methods", "dwa1,dwa3"]]) == 0
    saved = {name: (out / name).read_bytes() for name in ("results.csv", "meta.json", "table.md")}
    capsys.readouterr()

    line = refused(capsys, *base, "--methods", "dwa1")  # fewer methods than the directory holds
    assert f"{out / 'results.csv'}: holds 1 episode(s)" in line and "methods dwa3" in line
    line = refused(capsys, *base, "--methods", "dwa1,dwa3", "--physics-hz", "120")
    assert "sim.physics_hz 240 there, 120 here" in line
    line = refused(capsys, *base, "--methods", "dwa1,dwa3", "--noise", "paper")
    assert "noise none" in line
    assert {name: (out / name).read_bytes() for name in saved} == saved  # nothing rewritten

    # Extending (more seeds, a method) is a merge: the table covers every row of the CSV.
    more = [*base, "--methods", "dwa1,dwa3,random", "--seeds", "2"]
    assert main([str(a) for a in more]) == 0
    meta = json.loads((out / "meta.json").read_text())
    assert csv_keys(out) == {(w, m, str(s)) for w, m, _, s, _ in meta["jobs"]}
    # the fixed methods repeat their noise-free episode: no second seed; the random one has it
    assert len(csv_keys(out)) == 4 and table_methods(out) == {
        "DWA I (1,1,2)", "DWA III (2,1,1)", "Random (uniform over 100 actions)"
    }  # fmt: skip
    capsys.readouterr()
    line = refused(capsys, *base, "--methods", "dwa1,dwa3")  # back to one seed: refused
    assert "seeds 1" in line


def test_eval_refuses_a_world_of_the_same_name_from_another_file(tmp_path, capsys, tiny):
    out = tmp_path / "res"
    assert main([str(a) for a in eval_args(tiny, out)]) == 0
    other = tmp_path / "other" / "tiny.yaml"
    other.parent.mkdir()
    other.write_text(yaml.safe_dump(dict(TINY, goal=[1.2, 0.0])))
    capsys.readouterr()
    line = refused(capsys, *eval_args(other, out))
    assert "world 'tiny' came from" in line and str(other) in line


def test_sweep_refuses_another_time_limit_in_the_same_directory(tmp_path, capsys, tiny):
    out = tmp_path / "sw"
    args = ["sweep", "--methods", "dwa1", "--worlds", tiny, "--styles", "", "--layouts", "0",
            "--axes", "", "--profiles", "none", "--seeds", "1", "--workers", "1", "--out", out]  # fmt: skip
    assert main([str(a) for a in [*args, "--time-limit", "0.5"]]) == 0
    capsys.readouterr()
    line = refused(capsys, *args, "--time-limit", "0.8")
    assert "--time-limit 0.5" in line and "0.8" in line


@pytest.mark.parametrize("option", ["--methods", "--worlds"])
def test_an_empty_list_is_refused_not_read_as_the_default(
    tmp_path, capsys, tiny, option, no_episode
):
    args = {"--methods": "dwa1", "--worlds": str(tiny)} | {option: ""}
    line = refused(capsys, "eval", *[x for kv in args.items() for x in kv], "--out", tmp_path / "r")
    assert f"{option} is empty" in line


@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_a_policy_beside_several_methods_is_refused_not_ignored(tmp_path, capsys, command):
    line = refused(capsys, command, "--methods", "dwa1,d3dwa", "--policy", tmp_path / "p",
                   "--out", tmp_path / "r")  # fmt: skip
    assert "--policy" in line and "--methods dwa1,d3dwa" in line and not (tmp_path / "r").exists()


def test_eval_checks_the_noise_profile_before_creating_anything(tmp_path, capsys, tiny):
    line = refused(capsys, *eval_args(tiny, tmp_path / "r", "--noise", "bogus"))
    assert "unknown profile 'bogus'" in line and not (tmp_path / "r").exists()


def test_sweep_refuses_empty_methods(tmp_path, capsys):
    assert "--methods is empty" in refused(capsys, "sweep", "--methods", ",", "--out", tmp_path)


def test_a_results_row_that_is_not_one_is_named(tmp_path, capsys, tiny):
    out = tmp_path / "res"
    assert main([str(a) for a in eval_args(tiny, out)]) == 0
    capsys.readouterr()
    text = (out / "results.csv").read_text().replace(",0,none,", ",zero,none,")
    (out / "results.csv").write_text(text)
    assert f"{out / 'results.csv'}: line 2: not a results row" in refused(capsys, "report", out)


# 7. compare-scans with scans that are not scans ------------------------------------------


def test_compare_scans_refuses_a_bag_whose_scans_all_have_zero_beams(tmp_path, capsys):
    a = write_scan_bag(tmp_path / "a", [[1.0] * 21] * 3)
    b = write_scan_bag(tmp_path / "b", [[]] * 5)
    line = refused(capsys, "compare-scans", a, b)
    assert f"{b}: no scan on '{TopicMap().scan}' to compare" in line
    assert "5 messages: 5 zero beams" in line and f"{a}:" not in line


def test_compare_scans_says_what_it_left_out(tmp_path, capsys):
    a = write_scan_bag(tmp_path / "a", [[1.0] * 21] * 3)
    b = write_scan_bag(tmp_path / "b", [[1.0] * 21, [], [2.0] * 21, []])
    code, out, err = run(capsys, "compare-scans", a, b)
    assert code == 0, err
    assert "b: 2 of 4 scan messages left out (2 zero beams)" in out.splitlines()[1]
    code, out, err = run(capsys, "compare-scans", a, b, "--json")
    result = strict_json(out)
    assert result["b"]["skipped"] == {"zero beams": 2} and result["a"]["skipped"] == {}
    assert (result["b"]["scans"], result["b"]["scan_messages"]) == (2, 4)


# 9. record: --overwrite, Ctrl-C; a pickled checkpoint; Ctrl-C elsewhere ------------------


def test_record_into_an_existing_bag_names_overwrite(tmp_path, capsys, tiny):
    bag = write_scan_bag(tmp_path / "bag", [[1.0] * 21])
    before = files_in(bag)
    line = refused(capsys, "record", "--world", tiny, "--method", "dwa1", "--out", bag)
    assert f"{bag}: bag exists; pass --overwrite" in line and "overwrite=True" not in line
    assert files_in(bag) == before
    (tmp_path / "mine").mkdir()
    line = refused(
        capsys, "record", "--world", tiny, "--method", "dwa1", "--out", tmp_path / "mine"
    )
    assert "exists and is not a bag" in line


def test_ctrl_c_during_record_keeps_the_bag_and_says_so(tmp_path, capsys, monkeypatch, tiny):
    def interrupted_episode(world, method, policy, noise, seed, recorder, **_):
        for k in range(3):
            t = (k + 1) * 100 * MS
            scan = LaserScan(-1.0, 0.1, np.ones(21), 0.05, 10.0, t)
            recorder.write_step(t, scan, (0.1 * k, 0.0, 0.0), (0.1, 0.0), cmd=(0.1, 0.0))
        raise KeyboardInterrupt

    monkeypatch.setattr(sim_bridge, "record_episode", interrupted_episode)
    code, _, err = run(
        capsys, "record", "--world", tiny, "--method", "dwa1", "--out", tmp_path / "b"
    )
    lines = err.strip().splitlines()
    assert code == 130 and len(lines) == 1 and lines[0].startswith("d3dwa: interrupted; ")
    assert "results.csv" not in lines[0] and "the bag keeps the" in lines[0]
    assert replay_bag(tmp_path / "b", goal=(1.0, 0.0)).replayed == 3  # closed and readable


def test_ctrl_c_during_run_mentions_no_results_csv(capsys, monkeypatch, tiny):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(episode_module, "run_episode", interrupted)
    code, _, err = run(capsys, "run", "--world", tiny, "--method", "dwa1")
    assert code == 130 and "results.csv" not in err and len(err.strip().splitlines()) == 1


def test_ctrl_c_during_eval_still_points_at_results_csv(tmp_path, capsys, monkeypatch, tiny):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("d3dwa_bullet.evaluation.jobs.run_episode", interrupted)
    code, _, err = run(capsys, *eval_args(tiny, tmp_path / "res"))
    assert code == 130 and err.strip().endswith("finished episodes are kept in results.csv")


def test_ctrl_c_during_replay_points_at_replay_csv(tmp_path, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("d3dwa_bullet.cli.transfer.replay_bag", interrupted)
    code, _, err = run(capsys, "replay", tmp_path / "bag", "--out", tmp_path / "o")
    assert code == 130 and err.strip() == (
        f"d3dwa: interrupted; the scans replayed so far are in {tmp_path / 'o' / 'replay.csv'}"
    )


class NotATensor:
    """A class torch's weights-only loader refuses to unpickle."""


def test_a_pickled_checkpoint_is_one_line_without_torchs_advice(tmp_path, capsys, tiny):
    from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
    from d3dwa_bullet.planning.actions import ACTIONS_WEIGHTS_ONLY

    agent = D3QNAgent(ACTIONS_WEIGHTS_ONLY, D3QNConfig(hidden=(8,), seed=1))
    policy = save_checkpoint(tmp_path / "pol", agent, method="d3dwa-weights")
    weights = policy / "weights.pt"
    # a pickle as large as the network's weights (the size check passes) that is no tensors
    torch.save({"w": NotATensor(), "pad": b"\0" * weights.stat().st_size}, weights)
    data = weights.read_bytes()  # meta.json agrees, so only the loader can refuse it
    meta = json.loads((policy / "meta.json").read_text())
    meta["files"]["weights.pt"] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (policy / "meta.json").write_text(json.dumps(meta))
    line = refused(capsys, "run", "--world", tiny, "--method", "d3dwa-weights", "--policy", policy)
    assert f"{weights}: cannot be read as tensors" in line and "NotATensor" in line
    assert "weights_only" not in line and "safe_globals" not in line


# 10. strict JSON, and worlds from which no obstacle could be built -----------------------


def test_strict_json_writes_null_for_non_finite_values():
    value = {"a": math.inf, "b": [1.0, math.nan, (-math.inf, 2)], "c": np.float64("nan"), "d": 3}
    assert strict(value) == {"a": None, "b": [1.0, None, [None, 2]], "c": None, "d": 3}
    assert strict_json(json_text(value)) == strict(value)


def test_run_json_of_an_empty_world_is_strict(tmp_path, capsys):
    path = tmp_path / "open.yaml"
    path.write_text(yaml.safe_dump(dict(TINY, name="open", obstacles=[])))  # empty on purpose
    code, out, err = run(capsys, *run_args(path, "--json"))
    assert code == 0, err
    assert strict_json(out)["min_clearance_m"] is None
    code, out, err = run(capsys, *eval_args(path, tmp_path / "res"), "--json")
    assert code == 0, err
    assert strict_json(out)[0]["min_clearance_m"] is None


def test_an_sdf_of_meshes_is_refused_unless_allow_empty(tmp_path, capsys, recwarn):
    sdf = tmp_path / "meshes.world"
    sdf.write_text(MESH_ONLY_SDF)
    line = refused(capsys, *run_args(sdf))
    assert f"{sdf}: no obstacle could be built" in line and "mesh geometry" in line
    assert "--allow-empty" in line and "model://ground_plane" in line
    line = refused(capsys, *eval_args(sdf, tmp_path / "res"))
    assert "--allow-empty" in line and not (tmp_path / "res").exists()
    line = refused(capsys, "record", "--world", sdf, "--method", "dwa1", "--out", tmp_path / "b")
    assert "--allow-empty" in line and not (tmp_path / "b").exists()
    line = refused(capsys, "sweep", "--methods", "dwa1", "--worlds", sdf, "--out", tmp_path / "s")
    assert "--allow-empty" in line and not (tmp_path / "s").exists()

    code, out, err = run(
        capsys, *run_args(sdf, "--allow-empty", "--json", "--start", "0,0,0", "--goal", "1,0")
    )
    assert code == 0, err
    summary = strict_json(out)
    assert summary["world"] == "meshes" and summary["min_clearance_m"] is None


def test_a_map_with_no_occupied_cell_is_refused_unless_allow_empty(tmp_path, capsys):
    cv2.imwrite(str(tmp_path / "free.pgm"), np.full((20, 20), 254, dtype=np.uint8))
    spec = {"image": "free.pgm", "resolution": 0.05, "origin": [-0.5, -0.5, 0.0],
            "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}  # fmt: skip
    (tmp_path / "free.yaml").write_text(yaml.safe_dump(spec))
    line = refused(capsys, *run_args(tmp_path / "free.yaml"))
    assert "no obstacle could be built from this map_server world" in line
    code, _, err = run(capsys, *run_args(tmp_path / "free.yaml", "--allow-empty"))
    assert code == 0, err


def test_a_closed_stdout_ends_the_command_quietly():
    """`d3dwa worlds | head -0`: the reader is gone before the first line; no traceback."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "d3dwa_bullet.cli", "worlds"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None
    proc.stdout.close()  # long before the command has imported enough to print
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 141, err
    assert err == b""
