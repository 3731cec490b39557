"""meta.json lists the key of every job of a run, so it grows with the run: one line per key,
read under its own limit (a sweep's job list is larger than any config document)."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation import results
from d3dwa_bullet.evaluation.results import read_meta, write_meta
from d3dwa_bullet.limits import MAX_DOCUMENT_BYTES, Limit

FIELDS = ["world", "method"]


def keys(n: int) -> list[tuple[object, ...]]:
    return [
        (f"R3-style-s{2147483648 + i}", "random-weights@10", i % 5, 0, "harsh") for i in range(n)
    ]


def test_each_job_key_takes_one_line_and_reads_back(tmp_path):
    jobs = keys(3)
    write_meta(tmp_path, EpisodeConfig(), {"kind": "sweep"}, FIELDS, jobs)
    lines = (tmp_path / "meta.json").read_text().splitlines()
    assert [json.loads(line.strip().rstrip(",")) for line in lines[-5:-2]] == [
        list(k) for k in jobs
    ]
    assert read_meta(tmp_path)["jobs"] == [list(k) for k in jobs]
    assert read_meta(tmp_path)["settings"] == {"kind": "sweep"}


def test_a_run_without_jobs_still_writes_json(tmp_path):
    write_meta(tmp_path, EpisodeConfig(), {"kind": "eval"}, FIELDS, [])
    assert read_meta(tmp_path)["jobs"] == []


def test_a_job_list_larger_than_a_document_reads(tmp_path):
    jobs = keys(80_000)  # about 5 MB, over the 4 MiB a config document may take
    write_meta(tmp_path, EpisodeConfig(), {"kind": "sweep"}, FIELDS, jobs)
    assert (tmp_path / "meta.json").stat().st_size > MAX_DOCUMENT_BYTES.value
    assert len(read_meta(tmp_path)["jobs"]) == 80_000


def test_a_meta_json_over_its_limit_is_refused_in_one_line(tmp_path, monkeypatch):
    write_meta(tmp_path, EpisodeConfig(), {"kind": "sweep"}, FIELDS, keys(100))
    monkeypatch.setattr(results, "MAX_RUN_META_BYTES", Limit(1000, "a run's meta.json"))
    with pytest.raises(
        ResultsError, match=r"meta\.json: \d+ bytes is over the limit of 1000 bytes"
    ) as err:
        read_meta(tmp_path)
    assert "\n" not in str(err.value)
