"""Hand-edited results are checked for the newer columns (issue 42, class 6): a ``recovery``
column mixing tracks or naming no recovery layer, and a ``policy_notes`` of the wrong type in
meta.json, are one line naming the file (and line and value), never pooled or a traceback."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.columns import RECOVERY_FIELD
from d3dwa_bullet.evaluation.report import policy_notes
from d3dwa_bullet.evaluation.results import CSV_FIELDS, read_results
from tests.conftest import ONE_SECOND_WORLD
from tests.evaluation.test_results_rows import GOOD
from tests.support.cli import refused, run

FIELDS = (*CSV_FIELDS, RECOVERY_FIELD)


def _rows(out: Path, *tracks: str) -> Path:
    out.mkdir(exist_ok=True)
    rows = [GOOD | {"seed": str(k), RECOVERY_FIELD: t} for k, t in enumerate(tracks)]
    lines = [",".join(FIELDS)] + [",".join(r[k] for k in FIELDS) for r in rows]
    (out / "results.csv").write_text("\n".join(lines) + "\n")
    return out / "results.csv"


@pytest.mark.parametrize("track", ["nav2", "none"])
def test_rows_of_one_track_read(tmp_path, track):
    _rows(tmp_path, track, track)
    assert {r[RECOVERY_FIELD] for r in read_results(tmp_path)} == {track}


def test_a_column_mixing_tracks_is_refused_naming_file_line_and_value(tmp_path):
    path = _rows(tmp_path, "nav2", "nav2", "none")
    with pytest.raises(ResultsError) as err:
        read_results(tmp_path)
    message = str(err.value)
    assert message.startswith(f"{path}: line 4: column 'recovery' is 'none' but line 2 is 'nav2'")
    assert "\n" not in message


def test_an_unknown_recovery_value_is_refused(tmp_path):
    path = _rows(tmp_path, "nav2", "spin-forever")
    expected = f"{path}: line 3: column 'recovery' is 'spin-forever', not one of none, nav2"
    with pytest.raises(ResultsError, match=f"^{re.escape(expected)}$"):
        read_results(tmp_path)


@pytest.mark.parametrize("bad", ["a note", {"a": 1}, [1, 2], ["ok", None]])
def test_policy_notes_of_the_wrong_type_are_refused(tmp_path, bad):
    with pytest.raises(ResultsError, match="settings.policy_notes is .*expected a list of strings"):
        policy_notes(tmp_path, {"settings": {"policy_notes": bad}})
    long = ["x" * 2**20]
    assert len(policy_notes(tmp_path, {"settings": {"policy_notes": long}})[0]) < 2**12


def test_report_refuses_bad_notes_and_mixed_tracks_in_one_line(tmp_path, capsys):
    world = tmp_path / "tiny.yaml"
    world.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    out = tmp_path / "res"
    argv = ["eval", "--methods", "dwa1", "--worlds", world, "--workers", "1", "--out", out]
    assert run(capsys, *argv)[0] == 0
    meta = json.loads((out / "meta.json").read_text())
    meta["settings"]["policy_notes"] = "not a list"
    (out / "meta.json").write_text(json.dumps(meta))
    line = refused(capsys, "report", out)
    assert "settings.policy_notes is 'not a list'" in line and str(out / "meta.json") in line
