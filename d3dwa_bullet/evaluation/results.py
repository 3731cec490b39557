"""A results directory on disk: reading and writing it, resuming it, judging it complete.

A results directory holds (and, while a command writes it, ``.d3dwa.lock``: see
:mod:`d3dwa_bullet.dir_lock`)::

    meta.json          format version, package version, episode config, the command's
                       settings and the key of every job of the last run (what "complete" means)
    results.csv        one row per finished episode, with its score (SCORE_FIELDS,
                       docs/design/score.md#score): appended as episodes finish, then, once every
                       job of the run is in, rewritten in the order the jobs were listed
    logs/*.npz         the per-step log of every episode (pose, command, weights, tau, obs)
    table.md           Table I layout, written only once every episode is in results.csv
    figures/*.png      one trajectory figure per world (all methods side by side)

Rows are appended and flushed one by one, so an interrupted run loses nothing finished;
running the same command again skips episodes already in results.csv (a row cut short by
a kill is dropped and its episode rerun). The final rewrite in job order makes the file the
same bytes whatever the number of workers and the order episodes finished in. Pages derived
from the rows (table.md, sweep.md, report.md) are deleted when a run starts with episodes
to do and rewritten once it is complete, so a stale page never poses as the result of the
current job set. Every whole-file write is atomic (:mod:`d3dwa_bullet.io`).

A run into a directory that already holds rows may resume it or extend it (more methods,
worlds or seeds), never shrink or mix it: :func:`~d3dwa_bullet.evaluation.same_run.check_same_run` refuses a run whose jobs
leave out rows of results.csv (meta.json and the pages would then describe fewer rows than
the file holds) or whose episodes would be computed otherwise than the rows already there
(another episode config, world file, time limit, policy, or a policy's weights).
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation.columns import (
    GLOBAL_PLAN_FIELD,
    RECOVERY_FIELD,
    SOURCE_FIELD,
    TYPED_COLUMNS,
    check_one_track,
)
from d3dwa_bullet.evaluation.repeats import Key, kept_keys
from d3dwa_bullet.io import AppendFile, atomic_write_bytes, atomic_write_text, read_text
from d3dwa_bullet.limits import MAX_RUN_META_BYTES
from d3dwa_bullet.loading import load_json

if TYPE_CHECKING:  # for annotations only: this module reads and writes files, runs nothing
    from d3dwa_bullet.episode import EpisodeResult

RESULTS_FORMAT = 4
"""4: rows carry the episode score (3: no score; 2: no policy seed; 1: no job keys)."""
UNSCORED_FORMAT = 3
"""The format before the score: still read (its rows' score columns are None, tables say so)
and, resumed by eval or sweep, brought to RESULTS_FORMAT by scoring its rows (scores.py)."""
SCORE_FIELDS = ("score", "score_barn", "reference_length_m")
"""The score columns (docs/design/score.md#score): robot form, BARN's official form, and L, m."""
CSV_FIELDS = (
    "world",
    "method",
    "policy_seed",
    "seed",
    "noise",
    "outcome",
    "time_s",
    "tl_m",
    "pd_rad",
    "min_clearance_m",
    "steps",
    *SCORE_FIELDS,
)
DERIVED_PAGES = ("table.md", "sweep.md", "report.md")
"""Pages computed from results.csv; removed while a run is incomplete."""

KEY_FIELDS = ("world", "method", "policy_seed", "seed", "noise")
EPISODE_SETTINGS = {
    "time_limit": "--time-limit", "policy": "--policy", "policy_root": "--policy-root",
    "recovery": "--recovery",
    GLOBAL_PLAN_FIELD: "--global-plan",
}  # fmt: skip
"""Settings (meta.json "settings") that change an episode but not its key, with the option
that sets them: one directory holds one value of each."""


def unscored(fields: Sequence[str]) -> list[str]:
    """The columns a run of ``fields`` wrote before the score (UNSCORED_FORMAT)."""
    return [f for f in fields if f not in SCORE_FIELDS]


def backend_of(out: Path, meta: Mapping[str, Any] | None = None) -> str:
    """The --backend a results directory's episodes ran on ("pybullet" when meta.json names none)."""
    meta = read_meta(out) if meta is None else meta
    return str(meta.get("settings", {}).get("backend", "pybullet"))


def recovery_of(out: Path, meta: Mapping[str, Any] | None = None) -> str:
    """The --recovery a results directory's episodes ran with ("none" for the paper track).
    meta: the directory's meta.json if already read."""
    meta = read_meta(out) if meta is None else meta
    return str(meta.get("settings", {}).get("recovery", "none"))


def row_key(row: Mapping[str, Any]) -> Key:
    """The key of a typed results row (see :func:`read_results`)."""
    return (row["world"], row["method"], row["policy_seed"], row["seed"], row["noise"])


def once_per_layout(rows: Sequence[Mapping[str, Any]]) -> list[Any]:
    """rows with each episode that repeats at every evaluation seed counted once, at its first
    seed (``repeats.kept_keys``): a directory from before that rule reads as one from since."""
    kept = set(kept_keys(row_key(r) for r in rows))
    return [r for r in rows if row_key(r) in kept]


def policy_seed_cell(policy_seed: int | None) -> str:
    """The results.csv cell of a policy seed ('' for None)."""
    return "" if policy_seed is None else str(policy_seed)


def read_results(out: Path) -> list[dict[str, Any]]:
    """Rows of results.csv with typed values (empty if absent)."""
    path = out / "results.csv"
    if not path.exists():
        return []
    rows = list(csv.DictReader(io.StringIO(read_text(path, ResultsError, "CSV file"), newline="")))
    for line, row in enumerate(rows, start=2):
        if set(CSV_FIELDS) - set(SCORE_FIELDS) - set(row):
            missing = set(CSV_FIELDS) - set(SCORE_FIELDS) - set(row)
            raise ResultsError(f"{path}: missing columns {sorted(missing)}")
        for column in SCORE_FIELDS:  # a directory from before the score: no score, said so
            row.setdefault(column, None)
        for column, (parse, expected) in TYPED_COLUMNS.items():
            if row[column] is None and column in SCORE_FIELDS:
                continue
            try:
                row[column] = parse(row[column])
            except (TypeError, ValueError) as err:  # TypeError: a row shorter than the header
                raise ResultsError(
                    f"{path}: line {line}: not a results row: column {column!r} is "
                    f"{row[column]!r}, not {expected}"
                ) from err
        row[RECOVERY_FIELD] = row.get(RECOVERY_FIELD) or "none"
    check_one_track(path, rows, RECOVERY_FIELD)
    check_rows_once(path, rows)
    return rows


def check_rows_once(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """ResultsError if two rows are one episode (the same world, method, training seed, seed
    and noise): a row written twice, by hand or by a copy, would count twice in every table."""
    first: dict[Key, int] = {}
    for line, row in enumerate(rows, start=2):
        seen = first.setdefault(row_key(row), line)
        if seen != line:
            world, method, policy_seed, seed, noise = row_key(row)
            trained = "" if policy_seed is None else f", training seed {policy_seed}"
            raise ResultsError(
                f"{path}: line {line} repeats the episode of line {seen} (world {world!r}, "
                f"method {method!r}{trained}, seed {seed}, noise {noise!r}); an episode is one "
                "row: remove the copy"
            )


def read_meta(out: Path) -> dict[str, Any]:
    """meta.json of a results directory ({} if absent)."""
    meta = out / "meta.json"
    if not meta.exists():
        return {}
    data = load_json(meta, ResultsError, "JSON file", MAX_RUN_META_BYTES)
    if not isinstance(data, dict):
        raise ResultsError(f"{meta}: expected a JSON object, got {type(data).__name__}")
    return data


def write_meta(
    out: Path,
    config: Any,
    settings: Mapping[str, Any],
    fields: Sequence[str],
    keys: Sequence[Key],
) -> None:
    """meta.json of a run: config is the run's EpisodeConfig (a dataclass), keys its jobs'.
    Each job's key takes one line (a sweep lists a hundred thousand of them)."""
    meta = {
        "format": RESULTS_FORMAT,
        "version": __version__,
        "config": asdict(config),
        "settings": dict(settings),
        "columns": list(fields),
    }
    head = json.dumps(meta, indent=1, default=str).removesuffix("\n}")
    jobs = ",\n".join(f"  {json.dumps(list(k), default=str)}" for k in keys)
    text = f'{head},\n "jobs": [\n{jobs}\n ]\n}}' if jobs else f'{head},\n "jobs": []\n}}'
    atomic_write_text(out / "meta.json", text)


def csv_header(out: Path) -> list[str] | None:
    """The column names of out/results.csv (None if absent or empty)."""
    path = out / "results.csv"
    if not path.exists():
        return None
    with path.open(newline="", encoding="utf-8") as fh:
        return next(csv.reader(fh), None)


def check_results_dir(
    out: Path, fields: Sequence[str] | None = None, recovery: str | None = None,
    backend: str | None = None,
) -> None:  # fmt: skip
    """Refuse a results directory written by another format version, or (with fields) one
    whose results.csv has other columns (e.g. a sweep's directory given to eval), or (with
    recovery, the command's --recovery) one whose episodes ran with another recovery layer:
    the paper track and a recovery track never share a directory; nor (with backend, the
    command's --backend) do two simulator backends. A results.csv or
    meta.json that is a symbolic link is refused: a command never writes through one."""
    for name in ("results.csv", "meta.json"):
        if (out / name).is_symlink():
            raise ResultsError(
                f"{out / name}: is a symbolic link; a results directory holds only files d3dwa "
                "wrote there (remove the link, or use another --out directory)"
            )
    meta = out / "meta.json"
    if meta.exists():
        fmt = read_meta(out).get("format")
        if fmt not in (RESULTS_FORMAT, UNSCORED_FORMAT):
            raise ResultsError(
                f"{meta}: results format {fmt!r}, this version writes {RESULTS_FORMAT}; use a new --out directory"
            )
    elif (out / "results.csv").exists():
        raise ResultsError(
            f"{out}: results.csv without meta.json (older version?); use a new --out directory"
        )
    header = csv_header(out)
    there = recovery_of(out) if header is not None else None
    if recovery is not None and there is not None and there != recovery:
        raise ResultsError(
            f"{out / 'results.csv'}: its episodes ran with --recovery {there}, this command "
            f"has --recovery {recovery}; one directory holds one recovery setting: use "
            "another --out directory"
        )
    there = backend_of(out) if header is not None else None
    if backend is not None and there is not None and there != backend:
        raise ResultsError(
            f"{out / 'results.csv'}: its episodes ran on --backend {there}, this command has "
            f"--backend {backend}; one directory never mixes backends: use another --out directory"
        )
    if fields is not None and header is not None and header not in (list(fields), unscored(fields)):
        _check_sources(out, header, fields)
        kind = read_meta(out).get("settings", {}).get("kind", "another command")
        raise ResultsError(
            f"{out / 'results.csv'}: columns {header} were written by {kind!r}, this command "
            f"writes {list(fields)}; use another --out directory"
        )


def _check_sources(out: Path, header: Sequence[str], fields: Sequence[str]) -> None:
    """When results.csv and this run differ only in SOURCE_FIELD, the method list is the cause
    (a method from outside the package on one side only): say so, naming the methods there."""
    ours = [f for f in fields if f != SOURCE_FIELD]
    if [f for f in header if f != SOURCE_FIELD] not in (ours, unscored(ours)):
        return
    methods = ", ".join(read_meta(out).get("settings", {}).get("methods", [])) or "see meta.json"
    if SOURCE_FIELD in header:
        raise ResultsError(
            f"{out / 'results.csv'}: holds a method from outside the package (column "
            f"{SOURCE_FIELD}) and this run's --methods has none: to extend it, list the methods "
            f"already there ({methods}); else use another --out directory"
        )
    raise ResultsError(
        f"{out / 'results.csv'}: holds no method from outside the package (no column "
        f"{SOURCE_FIELD}) and this run's --methods adds one: run it into another --out directory"
    )


def drop_partial_row(path: Path) -> bool:
    """Cut a last line without its newline (a row half-written when the run was killed);
    True if something was cut. Its episode is then simply run again."""
    if not path.exists() or path.stat().st_size == 0:
        return False
    with os.fdopen(os.open(path, os.O_RDWR | os.O_NOFOLLOW), "rb+") as fh:  # not through a link
        fh.seek(-1, os.SEEK_END)
        if fh.read(1) == b"\n":
            return False
        fh.seek(0)
        data = fh.read()
        fh.seek(data.rfind(b"\n") + 1)
        fh.truncate()
    return True


@contextmanager
def appending_rows(out: Path, fields: Sequence[str]) -> Iterator[Any]:
    """A function ``append(row)`` that adds one row to out/results.csv and flushes it (the
    header first if the file is new or empty). Columns outside fields are ignored."""
    with AppendFile(out / "results.csv") as fh:  # whole rows, never through a link

        def line(write: Any) -> None:
            buffer = io.StringIO(newline="")
            write(csv.DictWriter(buffer, fieldnames=list(fields), extrasaction="ignore"))
            fh.write(buffer.getvalue().encode("utf-8"))

        if fh.size == 0:
            line(lambda writer: writer.writeheader())
        yield lambda row: line(lambda writer: writer.writerow(row))


def order_results(out: Path, keys: Sequence[Key]) -> bool:
    """Rewrite out/results.csv with the rows in the order of keys (atomically), rows of other
    jobs after them in their present order; True if the file changed. Values are rewritten
    as the strings they were written as, so the rows keep their bytes."""
    path = out / "results.csv"
    if not path.exists():
        return False
    data = path.read_bytes()
    table = list(csv.reader(io.StringIO(data.decode("utf-8"), newline="")))
    if not table:
        return False
    header, rows = table[0], table[1:]
    at = [header.index(name) for name in KEY_FIELDS]
    rank = {(w, m, policy_seed_cell(p), str(s), n): i for i, (w, m, p, s, n) in enumerate(keys)}
    last = len(rank)

    def position(row: list[str]) -> int:
        return rank.get(tuple(row[i] for i in at), last)  # type: ignore[arg-type]

    buffer = io.StringIO(newline="")
    csv.writer(buffer).writerows([header, *sorted(rows, key=position)])
    ordered = buffer.getvalue().encode("utf-8")
    if ordered == data:
        return False
    atomic_write_bytes(path, ordered)
    return True


def job_rows(out: Path, meta: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """The rows of results.csv that belong to the last run's jobs (meta.json "jobs"; every
    row if meta.json lists none), each episode that repeats at every evaluation seed counted
    once (:func:`once_per_layout`). meta: the directory's meta.json if already read."""
    meta = read_meta(out) if meta is None else meta
    keys = {tuple(k) for k in meta.get("jobs", [])}
    return once_per_layout([r for r in read_results(out) if not keys or row_key(r) in keys])


def completion(out: Path, rows: Sequence[dict[str, Any]] | None = None) -> tuple[int, int]:
    """(episodes finished, episodes in the last run's job list) of a results directory."""
    # a directory from before lists the repeats of a deterministic episode: counted once
    jobs = set(kept_keys(tuple(k) for k in read_meta(out).get("jobs", [])))
    rows = read_results(out) if rows is None else rows
    done = {row_key(r) for r in rows}
    return len(jobs & done), len(jobs)


def save_log(result: EpisodeResult, path: Path) -> None:
    """Per-step log as .npz (atomic): the outcome, the observations and every log array."""
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer, outcome=result.outcome, observations=result.observations, **result.log
    )
    atomic_write_bytes(path, buffer.getvalue())


def load_log(path: Path) -> dict[str, Any]:
    """The arrays of a log written by :func:`save_log`."""
    with np.load(path) as data:
        return {k: data[k] for k in data.files}
