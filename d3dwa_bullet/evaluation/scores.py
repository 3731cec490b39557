"""The score columns of results rows (docs/design/score.md#score), and scoring a directory made before.

A row's ``score`` (robot form, ``SCORE_FORM``) is a function of three of its own cells
(outcome, time_s, reference_length_m) and of the run's v_max (meta.json's episode config);
``score_barn`` (BARN's official form) of outcome, time_s and the world's official length
(BARN's published path on a BARN world, reference_length_m elsewhere): :func:`score_cells` computes them from the values as
written, so the same cells always give the same score, whoever computes it and when. That is
what lets :func:`add_scores` score the rows of a directory from before the score exactly as
a fresh run would, when eval or sweep resumes it: a results.csv never holds scored and
unscored rows side by side.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.episode_metrics import barn_score, episode_score
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.results import SCORE_FIELDS, csv_header, unscored
from d3dwa_bullet.io import atomic_write_bytes, read_text

LENGTH_DIGITS = 4
"""reference_length_m is written to 0.1 mm; the score is computed from the written value."""
SCORE_DIGITS = 6
UNSCORED_NOTE = (
    "No score: results from before the score (run the same eval or sweep command into this "
    "directory again to score its rows; no episode reruns)."
)
"""What a table says in place of the score for rows without one."""


def score_cells(
    outcome: str,
    time_s: float,
    reference_length: float,
    v_max: float,
    official_length: float | None = None,
) -> dict:
    """{"score", "score_barn", "reference_length_m"} of an episode: outcome (goal / collision
    / timeout), time_s as written in its row (s), reference_length L (m, the robot form's:
    ``world.routes.reference_length``), v_max (m/s), and official_length, the L of BARN's
    official form where the world publishes one (``world.routes.official_length``; None: L)."""
    length = round(float(reference_length), LENGTH_DIGITS)
    official = length if official_length is None else round(float(official_length), LENGTH_DIGITS)
    success = outcome == "goal"
    return {
        "score": round(episode_score(success, time_s, length, v_max), SCORE_DIGITS),
        "score_barn": round(barn_score(success, time_s, official), SCORE_DIGITS),
        "reference_length_m": length,
    }


def is_scored(rows: Sequence[Mapping[str, Any]]) -> bool:
    """True if every row has a score (a directory from before the score has none)."""
    return all(r.get("score") is not None for r in rows)


def needs_scores(out: Path, fields: Sequence[str]) -> bool:
    """True if out/results.csv was written before the score by a run of ``fields``."""
    header = csv_header(out)
    return header is not None and header != list(fields) and header == unscored(fields)


def add_scores(
    out: Path,
    fields: Sequence[str],
    lengths: Mapping[str, float],
    v_max: float,
    official: Mapping[str, float] | None = None,
) -> int:
    """Score every row of an unscored out/results.csv (atomically rewritten with ``fields``
    as header, the other cells as they were written); returns the rows scored.

    lengths: {world name: L, m} covering every row's world; v_max: m/s, the run's (the same
    as the rows', which check_same_run has checked); official: {world name: L of BARN's
    official form} where a world publishes one. ResultsError names a world without L."""
    path = out / "results.csv"
    text = read_text(path, ResultsError, "CSV file")
    rows = list(csv.DictReader(io.StringIO(text, newline="")))
    buffer = io.StringIO(newline="")
    writer = csv.DictWriter(buffer, fieldnames=list(fields))
    writer.writeheader()
    for line, row in enumerate(rows, start=2):
        if row["world"] not in lengths:
            raise ResultsError(
                f"{path}: line {line}: world {row['world']!r} is not in this run, so its rows "
                "cannot be scored; list it, or use another --out directory"
            )
        world = row["world"]
        cells = score_cells(
            row["outcome"], float(row["time_s"]), lengths[world], v_max, (official or {}).get(world)
        )
        writer.writerow(row | {k: cells[k] for k in SCORE_FIELDS})
    atomic_write_bytes(path, buffer.getvalue().encode("utf-8"))
    return len(rows)
