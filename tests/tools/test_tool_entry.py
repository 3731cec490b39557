"""The tools in ``tools/`` keep the CLI's contract (issue 42, class 5): an argparse error, a
garbage summary.json, a non-numeric decision period or a missing optional extra is one line
``<tool>: error: ...`` and exit status 2, never a traceback or a stray line."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest

from tests.support.held_policy import held_checkpoint
from tools.experiments import sb3_crosscheck, shipped_seeds

ROOT = Path(__file__).resolve().parents[2]
TOOLS = sorted(
    f"tools.{p.parent.name}.{p.stem}"
    for folder in ("experiments", "bench")
    for p in (ROOT / "tools" / folder).glob("*.py")
    if "def main(" in p.read_text()
)


def _one_line(capsys: pytest.CaptureFixture[str], tool: str, *names: str) -> str:
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and err.startswith(f"{tool}: error: "), err
    assert captured.out == "", captured.out
    for name in names:
        assert name in err, (name, err)
    return err


@pytest.mark.parametrize("module", TOOLS)
def test_every_tool_says_an_unknown_option_in_one_line(module, capsys):
    tool = module.rpartition(".")[2]
    main = importlib.import_module(module).main
    assert main(["--no-such-option-here"]) == 2
    _one_line(capsys, tool, "--help")  # the unknown option, or a missing required one


def _seed(root: Path, summary: object, **config: object) -> Path:
    folder = held_checkpoint(root / "d3dwa" / "seed-0", decision_steps=10, recovery="none")
    (folder / "summary.json").write_text(
        summary if isinstance(summary, str) else json.dumps(summary)
    )
    if config:
        (folder / "config.json").write_text(json.dumps(config))
    return folder


@pytest.mark.parametrize(
    ("summary", "named"),
    [("garbage", "not valid JSON"), ([1, 2], "JSON object"),
     ({"env_steps": "many", "wall_time_s": 1}, "env_steps")],
)  # fmt: skip
def test_shipped_seeds_on_a_garbage_summary_is_one_line(tmp_path, capsys, summary, named):
    folder = _seed(tmp_path, summary)
    assert shipped_seeds.main(["--policies", str(tmp_path)]) == 2
    _one_line(capsys, "shipped_seeds", str(folder / "summary.json"), named)


def test_shipped_seeds_on_a_non_numeric_decision_period_is_one_line(tmp_path, capsys):
    folder = _seed(tmp_path, {"env_steps": 10, "wall_time_s": 60}, decision_steps="ten")
    assert shipped_seeds.main(["--policies", str(tmp_path)]) == 2
    _one_line(capsys, "shipped_seeds", str(folder / "config.json"), "decision_steps", "'ten'")


def test_sb3_crosscheck_without_the_extra_says_so_in_one_line(monkeypatch, capsys):
    missing = ModuleNotFoundError("No module named 'stable_baselines3'", name="stable_baselines3")
    monkeypatch.setattr(sb3_crosscheck, "SB3_MISSING", missing)
    assert sb3_crosscheck.main(["--steps", "0"]) == 2
    _one_line(capsys, "sb3_crosscheck", "stable_baselines3", "[sb3]")


def test_a_non_numeric_period_without_a_meta_json_is_one_line_too(tmp_path, capsys):
    folder = tmp_path / "d3dwa" / "seed-0"
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps({"env_steps": 10, "wall_time_s": 60}))
    (folder / "config.json").write_text(json.dumps({"decision_steps": "ten"}))
    assert shipped_seeds.main(["--policies", str(tmp_path)]) == 2
    _one_line(capsys, "shipped_seeds", str(folder / "config.json"), "decision_steps", "'ten'")


CUT_WORLD = "name: cut\nbounds: [0, 0, 4, 4]\nobstacles:\n  - {type: box, centre: [1, 1"


@pytest.mark.parametrize(
    ("module", "argv"),
    [("tools.experiments.check_worlds", []), ("tools.experiments.probe_route", [])],
)
def test_a_world_file_cut_mid_way_is_one_line_without_a_caret(module, argv, tmp_path, capsys):
    """PyYAML's message spans lines (the source line, a caret); the loader makes it one, and a
    tool's own refusal is ``<tool>: error: ...`` like any other (issue 58, class 3)."""
    path = tmp_path / "cut.yaml"
    path.write_text(CUT_WORLD)
    tool = module.rpartition(".")[2]
    assert importlib.import_module(module).main([str(path), *argv]) == 2
    err = _one_line(capsys, tool, str(path), "not valid YAML", "line 4, column")
    assert "^" not in err
