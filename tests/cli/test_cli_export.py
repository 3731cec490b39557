"""``d3dwa export --onnx`` and ``d3dwa run --onnx``: every shipped seed exported and checked,
an exported policy driving the very episode its checkpoint drives, and one-line refusals
(exit 2) that leave nothing written."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.onnx_export import Q_TOLERANCE
from d3dwa_bullet.method_specs import ONNX_METHODS
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.observation_kinds import observation_layout
from d3dwa_bullet.seed_dirs import seed_dirs
from tests.support.cli import refused, run

SHIPPED = {m: seed_dirs(default_policy_path(m)) for m in ONNX_METHODS}
FIGURES = re.compile(
    r"max \|Q_onnx - Q_torch\| (\S+) \(\|Q\| up to (\S+)\) on (\d+) .* on (\d+)/(\d+)"
)


def files_under(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*") if p.is_file())


def test_export_writes_every_shipped_seed_and_reports_its_check(capsys, tmp_path: Path) -> None:
    code, out, err = run(capsys, "export", "--onnx", tmp_path)
    assert code == 0, err
    expected = sorted(f"{m}/seed-{k}.onnx" for m, seeds in SHIPPED.items() for k in seeds)
    # five seeds each, or more, of every network method with a policies/ folder
    shipping = [m for m in ONNX_METHODS if default_policy_path(m).exists()]
    assert len(expected) >= 5 * len(shipping) > 0 and files_under(tmp_path) == expected
    lines = out.strip().splitlines()
    assert len(lines) == len(expected)
    for line in lines:
        dq, q, checked, agree, total = FIGURES.search(line).groups()  # type: ignore[union-attr]
        assert float(dq) <= Q_TOLERANCE * max(1.0, float(q))
        assert agree == total == checked


def test_export_one_method_some_seeds_as_json(capsys, tmp_path: Path) -> None:
    code, out, _ = run(
        capsys, "export", "--onnx", tmp_path, "--method", "d3dwa", "--seeds", "1,3", "--json"
    )
    assert code == 0
    rows = json.loads(out)
    assert [Path(r["file"]).name for r in rows] == ["seed-1.onnx", "seed-3.onnx"]
    assert files_under(tmp_path) == ["d3dwa/seed-1.onnx", "d3dwa/seed-3.onnx"]
    assert all(r["actions"] == 100 and r["observation"] == "paper" for r in rows)
    assert all(
        r["agreement"] == 1.0 and r["policy"].endswith(f"seed-{k}")
        for r, k in zip(rows, (1, 3), strict=True)
    )


def test_a_progress_checkpoint_is_refused_for_a_paper_method(capsys, tmp_path: Path) -> None:
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(16,)), observation_layout("progress"))
    ckpt = save_checkpoint(tmp_path / "runs" / "best", agent, method="d3dwa")
    out_dir = tmp_path / "onnx"
    # a progress policy exported for a paper method does not fit it
    line = refused(capsys, "export", "--onnx", out_dir, "--method", "d3dwa", "--policy", ckpt)
    assert "'progress' observation" in line and "method 'd3dwa'" in line


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--method", "dwa9"], "unknown method 'dwa9'"),
        (["--method", "dqdwa"], "--method dqdwa: its policy is a Q-table"),
        (["--method", "dwa1"], "--method dwa1 is a fixed DWA"),
        (["--policy", "policies/d3dwa"], "--policy policies/d3dwa needs --method"),
        (["--method", "d3dwa", "--seeds", "7"], "has no seed-7 (it has seeds 0, 1, 2, 3, 4)"),
        (["--method", "d3dwa", "--seeds", "x"], "--seeds: 'x'"),
        (["--method", "d3dwa", "--policy", "{tmp}/empty"], "holds no checkpoint"),
        (["--method", "d3dwa", "--policy", "{tmp}/nowhere"], "does not exist"),
        (["--method", "d3dwa", "--policy", "{dqdwa}"], "a tabular policy (dqdwa) is a Q-table"),
        (["--method", "d3dwa", "--policy", "{d3dwa0}", "--seeds", "0"], "is one checkpoint"),
        (["--method", "d3dwa-weights", "--policy", "{d3dwa0}"], "action set"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(capsys, tmp_path: Path, argv, says) -> None:
    (tmp_path / "empty").mkdir()
    values = {
        "tmp": tmp_path,
        "dqdwa": save_checkpoint(tmp_path / "tabular", DQDWAAgent(), method="dqdwa"),
        "d3dwa0": SHIPPED["d3dwa"][0],
    }
    out_dir = tmp_path / "out"
    line = refused(capsys, "export", "--onnx", out_dir, *(a.format(**values) for a in argv))
    assert says in line
    assert not out_dir.exists() or files_under(out_dir) == []


def test_an_existing_file_as_the_output_directory_is_refused(capsys, tmp_path: Path) -> None:
    file = tmp_path / "taken"
    file.write_text("mine")
    line = refused(capsys, "export", "--onnx", file, "--method", "d3dwa")
    assert f"--onnx {file}: exists and is not a directory" in line
    assert file.read_text() == "mine"


def test_a_file_export_did_not_write_is_replaced_only_with_force(capsys, tmp_path: Path) -> None:
    argv = ["export", "--onnx", tmp_path, "--method", "d3dwa", "--seeds", "0"]
    target = tmp_path / "d3dwa" / "seed-0.onnx"
    target.parent.mkdir()
    target.write_text("my notes, not a policy")
    line = refused(capsys, *argv)
    assert f"{target} exists and is not a policy written by `d3dwa export`" in line
    assert "--force" in line and target.read_text() == "my notes, not a policy"
    assert run(capsys, *argv, "--force")[0] == 0
    policy = target.read_bytes()
    assert policy.startswith(b"\x08") and b"d3dwa.format_version" in policy
    assert run(capsys, *argv)[0] == 0  # a policy it wrote: replaced without --force
    assert target.read_bytes() == policy


@pytest.mark.parametrize("link", ["d3dwa", "d3dwa/seed-0.onnx"])
def test_export_never_writes_through_a_link_in_its_directory(capsys, tmp_path, link) -> None:
    out, outside = tmp_path / "out", tmp_path / "outside"
    outside.mkdir()
    (outside / "seed-0.onnx").write_text("not yours")
    if link == "d3dwa":
        out.mkdir()
        (out / "d3dwa").symlink_to(outside)
    else:
        (out / "d3dwa").mkdir(parents=True)
        (out / "d3dwa" / "seed-0.onnx").symlink_to(outside / "seed-0.onnx")
    argv = ["export", "--onnx", out, "--method", "d3dwa", "--seeds", "0", "--force"]
    line = refused(capsys, *argv)
    assert f"{out / link} is a symbolic link" in line
    assert files_under(outside) == ["seed-0.onnx"]
    assert (outside / "seed-0.onnx").read_text() == "not yours"
    assert (out / link).is_symlink()


@pytest.fixture(scope="module")
def d3dwa_onnx(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from d3dwa_bullet.learning.agents.onnx_export import export_onnx

    return export_onnx(SHIPPED["d3dwa"][0], tmp_path_factory.mktemp("run") / "d3dwa.onnx").file


def test_run_onnx_drives_the_same_episode_as_its_checkpoint(capsys, d3dwa_onnx: Path) -> None:
    episode = ["run", "--world", "R2", "--method", "d3dwa", "--time-limit", "20", "--json"]
    code, from_onnx, _ = run(capsys, *episode, "--onnx", d3dwa_onnx)
    assert code == 0
    code, from_torch, _ = run(capsys, *episode, "--policy", SHIPPED["d3dwa"][0])
    assert code == 0
    summary = json.loads(from_onnx)
    assert summary["steps"] > 10 and summary["tl_m"] > 0.1  # it moved
    assert summary == json.loads(from_torch)
    code, text, _ = run(capsys, *episode[:-1], "--time-limit", "0.5", "--onnx", d3dwa_onnx)
    assert code == 0 and f"policy: {d3dwa_onnx} (ONNX, exported for d3dwa)" in text


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--method", "d3dwa", "--policy", "{policy}"], "both name the policy: give one"),
        (["--method", "dwa1"], "method 'dwa1' does not run a network"),
        (["--method", "d3dwa-weights"], "method 'd3dwa-weights' decodes"),
    ],
)
def test_run_onnx_refusals(capsys, d3dwa_onnx: Path, argv, says) -> None:
    argv = [a.format(policy=SHIPPED["d3dwa"][0]) for a in argv]
    line = refused(capsys, "run", "--world", "R1", *argv, "--onnx", d3dwa_onnx)
    assert says in line


def test_run_onnx_not_a_model(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_text("hello")
    line = refused(capsys, "run", "--world", "R1", "--method", "d3dwa", "--onnx", bad)
    assert f"{bad}: not an ONNX model" in line
