"""results.csv rows are checked when read: a NaN or inf where a table averages, or an outcome
no table counts, is one ResultsError naming the file, the line and the column."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import yaml

from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.results import CSV_FIELDS, read_results
from tests.conftest import ONE_SECOND_WORLD
from tests.support.cli import refused, run

GOOD = {
    "world": "TS1", "method": "dwa1", "policy_seed": "", "seed": "0", "noise": "none",
    "outcome": "goal", "time_s": "12.3", "tl_m": "4.5", "pd_rad": "0.7",
    "min_clearance_m": "0.21", "steps": "123", "score": "0.813008", "score_barn": "0.162602",
    "reference_length_m": "4.0",
}  # fmt: skip


def write_rows(out: Path, *rows: dict[str, str]) -> Path:
    out.mkdir(exist_ok=True)
    lines = [",".join(CSV_FIELDS)] + [",".join(row[k] for k in CSV_FIELDS) for row in rows]
    (out / "results.csv").write_text("\n".join(lines) + "\n")
    return out / "results.csv"


def test_good_rows_read_typed_and_a_world_without_obstacles_has_infinite_clearance(tmp_path):
    write_rows(tmp_path, GOOD, GOOD | {"seed": "1", "min_clearance_m": "inf", "policy_seed": "3"})
    first, second = read_results(tmp_path)
    assert (first["seed"], first["policy_seed"], first["time_s"], first["steps"]) == (
        0, None, 12.3, 123
    )  # fmt: skip
    assert second["policy_seed"] == 3 and second["min_clearance_m"] == math.inf


@pytest.mark.parametrize(
    ("column", "value", "expected"),
    [
        ("time_s", "nan", "a finite number >= 0"),
        ("tl_m", "inf", "a finite number >= 0"),
        ("pd_rad", "-inf", "a finite number >= 0"),
        ("time_s", "-1.0", "a finite number >= 0"),
        ("min_clearance_m", "NaN", "a number, or inf for a world without obstacles"),
        ("min_clearance_m", "-inf", "a number, or inf for a world without obstacles"),
        ("outcome", "crash", "one of goal, collision, timeout"),
        ("outcome", "", "one of goal, collision, timeout"),
        ("seed", "-2", "a whole number >= 0"),
        ("steps", "1.5", "a whole number >= 0"),
        ("policy_seed", "x", "empty or a whole number >= 0"),
    ],
)
def test_a_hand_edited_cell_is_named_by_file_line_and_column(tmp_path, column, value, expected):
    path = write_rows(tmp_path, GOOD, GOOD | {"seed": "1", column: value})
    message = f"{path}: line 3: not a results row: column {column!r} is {value!r}, not {expected}"
    with pytest.raises(ResultsError, match=f"^{re.escape(message)}$"):
        read_results(tmp_path)


def test_report_refuses_a_nan_time_in_one_line(tmp_path, capsys):
    world = tmp_path / "tiny.yaml"
    world.write_text(yaml.safe_dump(ONE_SECOND_WORLD))
    out = tmp_path / "res"
    argv = ["eval", "--methods", "dwa1", "--worlds", world, "--workers", "1", "--out", out]
    assert run(capsys, *argv)[0] == 0
    header, row = (out / "results.csv").read_text().splitlines()
    cells = row.split(",")
    cells[header.split(",").index("time_s")] = "nan"
    (out / "results.csv").write_text(f"{header}\n{','.join(cells)}\n")
    line = refused(capsys, "report", out)
    assert line.endswith(f"{out / 'results.csv'}: line 2: not a results row: column 'time_s' "
                         "is 'nan', not a finite number >= 0")  # fmt: skip
    assert not (out / "report.md").exists()
