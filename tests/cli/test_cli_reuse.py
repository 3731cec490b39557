"""`d3dwa eval --reuse DIR` and `d3dwa sweep --reuse DIR`: episodes taken from another directory
are the rows a fresh run writes, byte for byte; a directory that ran other episodes is refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.evaluation.reuse import reused_lines
from tests.evaluation.test_policy_runs import seed_folder
from tests.support.cli import refused, run

EVAL = ["eval", "--methods", "dwa3,random", "--seeds", "3", "--noise", "real", "--workers", "1"]


def eval_argv(world: str, out: Path, *extra: object) -> list[object]:
    return [*EVAL, "--worlds", world, "--out", out, *extra]


@pytest.fixture(scope="module")
def fresh(one_second_world, tmp_path_factory) -> Path:
    """A plain evaluation: the directory reused, and the rows a reuse must reproduce."""
    out = tmp_path_factory.mktemp("fresh") / "a"
    assert main([str(a) for a in eval_argv(one_second_world, out)]) == 0
    return out


def copy_of(src: Path, dest: Path, logs: bool = True) -> Path:
    """A copy of a results directory (results.csv and meta.json; logs/ if asked)."""
    dest.mkdir(parents=True)
    for name in ("results.csv", "meta.json"):
        shutil.copyfile(src / name, dest / name)
    if logs:
        shutil.copytree(src / "logs", dest / "logs")
    return dest


def meta_settings(out: Path) -> dict:
    return json.loads((out / "meta.json").read_text())["settings"]


def test_reuse_writes_the_rows_a_fresh_run_writes(fresh, one_second_world, tmp_path, capsys):
    source = copy_of(fresh, tmp_path / "dir", logs=False)  # committed folders have no logs
    out = tmp_path / "out"
    code, printed, _ = run(capsys, *eval_argv(one_second_world, out, "--reuse", source))
    assert code == 0
    assert (out / "results.csv").read_bytes() == (fresh / "results.csv").read_bytes()
    assert meta_settings(out)["reused"] == [
        {"from": str(source.resolve()), "episodes": 3, "checked": 3}
    ]
    assert f"3 episodes reused from {source.resolve()} (3 rerun to check: identical)" in printed
    # the checked episodes have their fresh logs; DIR kept none of the others
    assert len(list((out / "logs").iterdir())) == 3
    code, _, _ = run(capsys, "report", out)
    assert code == 0
    assert "3 episodes reused from" in (out / "report.md").read_text()


def test_resume_after_reuse_keeps_the_record(fresh, one_second_world, tmp_path, capsys):
    source = copy_of(fresh, tmp_path / "dir")
    out = tmp_path / "out"
    assert (
        run(capsys, *eval_argv(one_second_world, out, "--reuse", source, "--reuse-check", "1"))[0]
        == 0
    )
    assert len(list((out / "logs").iterdir())) == 6  # DIR's logs are copied
    record = meta_settings(out)["reused"]
    # one check asked for, one more for the method it did not meet
    assert record == [{"from": str(source.resolve()), "episodes": 4, "checked": 2}]
    # a plain resume, then an extension to a fourth seed: the rows stay, the record too
    assert run(capsys, *eval_argv(one_second_world, out))[0] == 0
    extended = [*eval_argv(one_second_world, out)]
    extended[extended.index("3")] = "4"
    code, printed, _ = run(capsys, *extended)
    assert code == 0
    assert meta_settings(out)["reused"] == record
    assert "4 episodes reused from" in printed
    lines = (out / "results.csv").read_text().splitlines()
    assert len(lines) == 1 + 8  # in job order: each method's fourth seed after its third
    assert set((fresh / "results.csv").read_text().splitlines()) < set(lines)


def test_a_directory_with_another_config_is_refused(fresh, one_second_world, tmp_path, capsys):
    out = tmp_path / "out"
    line = refused(
        capsys, *eval_argv(one_second_world, out, "--physics-hz", "120", "--reuse", fresh)
    )
    assert "config.sim.physics_hz 240" in line and "120" in line
    assert not (out / "results.csv").exists() and not (out / "meta.json").exists()


def test_a_tampered_row_is_refused_and_nothing_written(fresh, one_second_world, tmp_path, capsys):
    source = copy_of(fresh, tmp_path / "dir")
    lines = (source / "results.csv").read_text().splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    cells = lines[1].rstrip("\n").split(",")
    at = header.index("time_s")
    cells[at] = str(float(cells[at]) + 0.1)
    lines[1] = ",".join(cells) + "\n"
    (source / "results.csv").write_text("".join(lines))
    out = tmp_path / "out"
    # one check: the first reusable episode in job order, the row changed here
    argv = eval_argv(one_second_world, out, "--reuse", source, "--reuse-check", "1")
    code, _, err = run(capsys, *argv)
    line = err.splitlines()[-1]  # after the check episode's progress bar
    assert code == 2 and line.startswith("d3dwa: error: --reuse ")
    assert "episode ('tiny', 'dwa3', None, 0, 'real') reran with time_s '1.0'" in line
    assert "has '1.1'" in line
    assert not (out / "results.csv").exists() and not (out / "meta.json").exists()


def test_a_changed_policy_digest_is_refused(one_second_world, tmp_path, capsys):
    folder = seed_folder(tmp_path / "policies", seeds=(0, 1))
    argv = ["eval", "--worlds", one_second_world, "--methods", "d3dwa", "--policy", folder,
            "--seeds", "1", "--workers", "1"]  # fmt: skip
    assert run(capsys, *argv, "--out", tmp_path / "a")[0] == 0
    meta = json.loads((tmp_path / "a" / "meta.json").read_text())
    meta["settings"]["policy_digests"]["d3dwa/seed-1"] = "0" * 64
    (tmp_path / "a" / "meta.json").write_text(json.dumps(meta))
    line = refused(capsys, *argv, "--out", tmp_path / "b", "--reuse", tmp_path / "a")
    assert "policy digest of 'd3dwa' seed 1" in line
    assert not (tmp_path / "b" / "results.csv").exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--reuse", "{dir}", "--reuse-check", "0"],
            "--reuse-check must be >= 1 (episodes rerun against DIR), got 0",
        ),
        (
            ["--reuse", "{dir}", "--reuse-check", "-2"],
            "--reuse-check must be >= 1 (episodes rerun against DIR), got -2",
        ),
        (["--reuse", "{out}"], "is the --out directory"),
        (["--reuse", "{empty}"], "not a results directory"),
    ],
)
def test_bad_reuse_options_are_refused(fresh, one_second_world, tmp_path, capsys, extra, message):
    out, empty = copy_of(fresh, tmp_path / "out"), tmp_path / "empty"
    empty.mkdir()
    extra = [e.format(out=out, empty=empty, dir=fresh) for e in extra]
    before = (out / "results.csv").read_bytes()
    assert message in refused(capsys, *eval_argv(one_second_world, out, *extra))
    assert (out / "results.csv").read_bytes() == before


def test_a_sweep_reuses_its_profiles_and_reruns_its_axis_levels(one_second_world, tmp_path, capsys):
    argv = ["sweep", "--worlds", one_second_world, "--layouts", "0", "--methods", "dwa3",
            "--axes", "slip", "--levels", "1", "--profiles", "none,real", "--seeds", "2",
            "--workers", "1", "--recovery", "nav2"]  # fmt: skip
    assert run(capsys, *argv, "--out", tmp_path / "a")[0] == 0
    reuse = ["--reuse", tmp_path / "a", "--reuse-check", "1"]
    code, printed, _ = run(capsys, *argv, "--out", tmp_path / "b", *reuse)
    assert code == 0
    assert (tmp_path / "b" / "results.csv").read_bytes() == (
        tmp_path / "a" / "results.csv"
    ).read_bytes()
    # none (1 episode: it repeats at every seed) and real (2) reusable; slip=0.4 (explicit noise)
    # rerun; checked: the one asked for (none) and real's first
    assert meta_settings(tmp_path / "b")["reused"][0] | {"from": ""} == {
        "from": "",
        "episodes": 1,
        "checked": 2,
    }
    assert "1 episode reused from" in printed and "(2 rerun to check: identical)" in printed
    # a sweep's directory has other columns than an evaluation's
    line = refused(capsys, *eval_argv(one_second_world, tmp_path / "e", "--reuse", tmp_path / "a"))
    assert "its results.csv has columns" in line and "'axis'" in line


def test_a_world_file_is_reused_only_by_its_content(fresh, one_second_world, tmp_path, capsys):
    source = copy_of(fresh, tmp_path / "dir")
    meta = json.loads((source / "meta.json").read_text())
    meta["settings"]["world_digests"]["tiny"] = "0" * 64  # another file, the same name
    (source / "meta.json").write_text(json.dumps(meta))
    line = refused(capsys, *eval_argv(one_second_world, tmp_path / "out", "--reuse", source))
    assert "its world 'tiny' differs" in line
    # a directory from before the digests: a world file's name proves nothing, its rows rerun
    del meta["settings"]["world_digests"]
    (source / "meta.json").write_text(json.dumps(meta))
    out = tmp_path / "out"
    assert run(capsys, *eval_argv(one_second_world, out, "--reuse", source))[0] == 0
    assert "reused" not in meta_settings(out)
    assert (out / "results.csv").read_bytes() == (fresh / "results.csv").read_bytes()


def test_a_named_world_of_a_directory_from_before_the_digests(tmp_path, capsys):
    # the yardstick's case: BARN worlds by name, a meta.json without world digests
    argv = ["sweep", "--worlds", "BARN-0", "--layouts", "0", "--methods", "dwa3,random",
            "--axes", "", "--profiles", "none,real", "--seeds", "2", "--time-limit", "1",
            "--workers", "1"]  # fmt: skip
    assert run(capsys, *argv, "--out", tmp_path / "a")[0] == 0
    meta = json.loads((tmp_path / "a" / "meta.json").read_text())
    del meta["settings"]["world_digests"]
    (tmp_path / "a" / "meta.json").write_text(json.dumps(meta))
    reuse = ["--reuse", tmp_path / "a", "--reuse-check", "2"]
    assert run(capsys, *argv, "--out", tmp_path / "b", *reuse)[0] == 0
    assert (tmp_path / "b" / "results.csv").read_bytes() == (
        tmp_path / "a" / "results.csv"
    ).read_bytes()
    # dwa3: none once, real twice; random: none and real twice each
    assert meta_settings(tmp_path / "b")["reused"][0]["episodes"] == 7 - 2
    longer = [*argv[:-4], "--time-limit", "2", "--workers", "1", "--out", tmp_path / "c", *reuse]
    assert "settings.time_limit 1.0" in refused(capsys, *longer)


def test_a_page_names_a_reused_directory_under_the_working_directory_relatively(
    tmp_path, monkeypatch
):
    # the record keeps DIR resolved; a page written in a checkout names no machine's path
    monkeypatch.chdir(tmp_path)
    record = {
        "reused": [
            {"from": str(tmp_path / "docs" / "runs"), "episodes": 1, "checked": 2},
            {"from": "/elsewhere/runs", "episodes": 3, "checked": 0},
        ]
    }
    assert reused_lines(record) == [
        f"1 episode reused from {Path('docs', 'runs')} (2 rerun to check: identical)",
        "3 episodes reused from /elsewhere/runs (0 rerun to check: identical)",
    ]
