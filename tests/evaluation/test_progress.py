"""The evaluation's progress bar: done/total over the whole job list, a resumed run included."""

from __future__ import annotations

import shutil
from typing import Any

import pytest

from d3dwa_bullet.evaluation import jobs as jobs_module
from d3dwa_bullet.evaluation.jobs import evaluate
from tests.evaluation.test_backends import FIELDS, jobs


class Bar:
    """Stands in for tqdm: keeps what the bar was made with and how far it went."""

    made: list[Bar] = []

    def __init__(self, total: int, initial: int = 0, **kwargs: Any) -> None:
        self.total, self.initial, self.n = total, initial, initial
        Bar.made.append(self)

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def update(self, n: int = 1) -> None:
        self.n += n

    def set_postfix_str(self, text: str) -> None:
        pass


@pytest.fixture
def bars(monkeypatch):
    Bar.made.clear()
    monkeypatch.setattr(jobs_module, "tqdm", Bar)
    return Bar.made


def test_a_fresh_run_counts_from_zero(tmp_path, bars):
    evaluate(jobs(), tmp_path, workers=1, fields=FIELDS)
    assert [(b.initial, b.n, b.total) for b in bars] == [(0, 4, 4)]


def test_a_resumed_run_counts_what_was_done_before(tmp_path, bars):
    full = tmp_path / "full"
    evaluate(jobs(), full, workers=1, fields=FIELDS)
    lines = (full / "results.csv").read_bytes().splitlines(keepends=True)
    part = tmp_path / "part"
    part.mkdir()
    (part / "results.csv").write_bytes(b"".join(lines[:3]))  # header and two episodes
    shutil.copy(full / "meta.json", part / "meta.json")
    bars.clear()
    evaluate(jobs(), part, workers=1, fields=FIELDS)
    assert [(b.initial, b.n, b.total) for b in bars] == [(2, 4, 4)]
    bars.clear()
    evaluate(jobs(), part, workers=1, fields=FIELDS)  # nothing left: the bar stands full
    assert [(b.initial, b.n, b.total) for b in bars] == [(4, 4, 4)]
