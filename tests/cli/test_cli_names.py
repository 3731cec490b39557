"""Small things a new user meets on the command line: a typo gets a "did you mean" and a short
line; ``--workers 0`` is refused (it once meant all cores); ``--noise``'s help names every
shipped profile, read from the profiles folder."""

from __future__ import annotations

import pytest
import yaml

from d3dwa_bullet.cli.app import build_parser
from randomization.profiles import list_profiles
from tests.conftest import ONE_SECOND_WORLD
from tests.support.cli import refused, run


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (
            ["run", "--world", "TS1", "--method", "d3dwaa"],
            "unknown method 'd3dwaa': did you mean 'd3dwa'?",
        ),
        (["run", "--world", "TS1", "--method", "rnadom"], "did you mean 'random'?"),
        (["run", "--world", "TS5", "--method", "dwa1"], "unknown world 'TS5': did you mean"),
        (["run", "--world", "TS1", "--method", "dwa1", "--noise", "reall"], "did you mean 'real'?"),
    ],
)
def test_a_typo_gets_did_you_mean(capsys, argv, said):
    assert said in refused(capsys, *argv)


def test_the_unknown_method_line_is_short_and_points_to_the_list(capsys):
    line = refused(capsys, "run", "--world", "TS1", "--method", "zzz")
    assert len(line) < 180 and "`d3dwa methods`" in line and "did you mean" not in line


@pytest.mark.parametrize("workers", ["0", "-1"])
@pytest.mark.parametrize("command", ["eval", "sweep"])
def test_workers_below_one_is_refused(capsys, tmp_path, command, workers):
    line = refused(
        capsys, command, "--methods", "dwa1", "--workers", workers, "--out", tmp_path / "r"
    )
    assert f"--workers must be >= 1, got {workers}" in line and not (tmp_path / "r").exists()


def test_noise_help_names_every_shipped_profile():
    parser = build_parser()
    for command in ("run", "eval", "serve"):
        sub = parser._subparsers._group_actions[0].choices[command]  # noqa: SLF001
        (noise,) = [a for a in sub._actions if "--noise" in a.option_strings]  # noqa: SLF001
        assert all(p in noise.help for p in list_profiles()) and len(list_profiles()) >= 7


def test_a_run_of_many_worlds_prints_the_summary_first_and_no_per_world_table(
    capsys, tmp_path, monkeypatch
):
    monkeypatch.setattr("d3dwa_bullet.evaluation.eval_summary.TERMINAL_WORLDS", 1)  # two are many
    worlds = []
    for name in ("tiny_a", "tiny_b"):
        path = tmp_path / f"{name}.yaml"
        path.write_text(yaml.safe_dump(ONE_SECOND_WORLD | {"name": name}))
        worlds.append(str(path))
    out = tmp_path / "r"
    code, printed, err = run(
        capsys,
        "eval",
        "--methods",
        "dwa1",
        "--worlds",
        ",".join(worlds),
        "--workers",
        1,
        "--out",
        out,
    )
    assert code == 0, err
    assert (
        printed.index("## Over every world (2 worlds; noise `none`; recovery layer off)")
        < printed.index("per-world tables (2 worlds):")
        < printed.index("figures: 2 in")
    )
    assert "| tiny_a |" not in printed and "| tiny_a |" in (out / "table.md").read_text()
    assert "| DWA I (1,1,2) | 1 evaluation seed | 0 | -- |" in printed  # one run: no interval
