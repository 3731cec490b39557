"""recipes_figure: methods of several sweeps side by side, per noise profile."""

from __future__ import annotations

import json

import pytest

from tests.tools.test_noise_sources import rows_for, sweep_dir
from tools.experiments import recipes_figure


@pytest.fixture
def sweeps(tmp_path):
    a = rows_for("dwa3", "none", ["goal", "timeout"]) + rows_for("dwa3", "harsh", ["goal"] * 2)
    b = rows_for("d3dwa-dr", "none", ["goal", "goal"], 0)
    b += rows_for("d3dwa-dr", "none", ["goal", "timeout"], 1)
    b += rows_for("d3dwa-dr", "harsh", ["timeout", "timeout"], 0)
    b += rows_for("d3dwa-dr", "harsh", ["goal", "timeout"], 1)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    return sweep_dir(tmp_path / "a", a), sweep_dir(tmp_path / "b", b)


def test_each_bar_is_the_mean_over_layouts_of_its_entry(sweeps, tmp_path, capsys):
    a, b = sweeps
    out = tmp_path / "fig" / "recipes.png"
    argv = ["--out", str(out), "--json", f"DWA III={a}:dwa3", f"recipe X={b}:d3dwa-dr"]
    assert recipes_figure.main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data) == ["DWA III", "recipe X"] and list(data["DWA III"]) == ["none", "harsh"]
    assert data["DWA III"]["none"]["success"] == pytest.approx(0.5)
    assert data["recipe X"]["none"]["success"] == pytest.approx(0.75)  # seeds 1.0 and 0.5
    assert data["recipe X"]["harsh"]["success"] == pytest.approx(0.25)
    assert data["recipe X"]["harsh"]["low"] < 0.25 < data["recipe X"]["harsh"]["high"]
    assert out.read_bytes()[:4] == b"\x89PNG"


def test_entries_over_different_layouts_are_refused(sweeps, tmp_path, capsys):
    a, b = sweeps
    c = tmp_path / "c"
    c.mkdir()
    sweep_dir(c, rows_for("dwa3", "none", ["goal"] * 3) + rows_for("dwa3", "harsh", ["goal"] * 2))
    out = tmp_path / "f.png"
    assert recipes_figure.main(["--out", str(out), f"A={a}:dwa3", f"C={c}:dwa3"]) == 2
    err = capsys.readouterr().err.strip()
    assert "under 'none', 'C' has 3 layouts and 'A' 2" in err and len(err.splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ("no-equals", "is not LABEL=DIR:METHOD"),
        ("X=nowhere:dwa3", "no results.csv"),
        ("X=A:dwa1", "no rows of 'dwa1'"),
    ],  # fmt: skip
)
def test_a_bad_entry_is_one_line(sweeps, tmp_path, capsys, entry, message):
    a, _ = sweeps
    entry = entry.replace("=A:", f"={a}:")
    assert recipes_figure.main(["--out", str(tmp_path / "f.png"), entry]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert recipes_figure.main(["--out", str(tmp_path / "f.svg"), f"A={a}:dwa3"]) == 2
    assert "must end in .png" in capsys.readouterr().err
