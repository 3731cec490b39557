"""evaluate(..., reuse=Reuse(DIR, K)): which episodes are taken from DIR, and the progress bar."""

from __future__ import annotations

import json

import pytest

from d3dwa_bullet.evaluation import jobs as jobs_module
from d3dwa_bullet.evaluation import reuse as reuse_module
from d3dwa_bullet.evaluation.jobs import Job, evaluate
from d3dwa_bullet.evaluation.reuse import Reuse
from tests.evaluation.test_backends import TINY
from tests.evaluation.test_backends import jobs as axis_jobs
from tests.evaluation.test_progress import Bar

EXTERNAL = "tests.support.external_methods:BuiltinChooser"


def profile_jobs(methods: tuple[str, ...] = ("dwa3", "random")) -> list[Job]:
    """Four short episodes under a named profile: keys that fix their episode."""
    return [Job(TINY, m, s, "real") for m in methods for s in (0, 1)]


def reused(out) -> list[dict]:
    return json.loads((out / "meta.json").read_text())["settings"].get("reused", [])


@pytest.fixture
def bars(monkeypatch):
    Bar.made.clear()
    monkeypatch.setattr(jobs_module, "tqdm", Bar)
    monkeypatch.setattr(reuse_module, "tqdm", Bar)
    return Bar.made


def test_the_bar_starts_at_the_reused_episodes(tmp_path, bars):
    source = tmp_path / "dir"
    evaluate(profile_jobs(), source, workers=1)
    lines = (source / "results.csv").read_bytes().splitlines(keepends=True)
    (source / "results.csv").write_bytes(b"".join(lines[:4]))  # header and three episodes
    bars.clear()
    evaluate(profile_jobs(), tmp_path / "out", workers=1, reuse=Reuse(source, 1))
    # the check bar (one episode), then the episodes' from the two taken and the one checked
    assert [(b.initial, b.n, b.total) for b in bars] == [(0, 1, 1), (3, 4, 4)]
    assert reused(tmp_path / "out")[0]["episodes"] == 2


def test_explicit_noise_and_outside_methods_are_run_not_reused(tmp_path):
    for name, jobs in (("axis", axis_jobs()), ("external", profile_jobs((EXTERNAL,)))):
        source, out = tmp_path / f"{name}-dir", tmp_path / f"{name}-out"
        evaluate(jobs, source, workers=1, progress=False)
        evaluate(jobs, out, workers=1, progress=False, reuse=Reuse(source, 1))
        assert reused(out) == []
        assert (out / "results.csv").read_bytes() == (source / "results.csv").read_bytes()


def test_the_checks_are_evenly_spaced_in_job_order(tmp_path):
    jobs = [Job(TINY, "random", s, "real") for s in range(7)]
    evaluate(jobs, tmp_path / "dir", workers=1, progress=False)
    plan = reuse_module.plan_reuse(
        Reuse(tmp_path / "dir", 3), jobs, jobs_module.EpisodeConfig(),
        json.loads((tmp_path / "dir" / "meta.json").read_text())["settings"],
        json.loads((tmp_path / "dir" / "meta.json").read_text())["columns"],
    )  # fmt: skip
    assert [j.seed for j in plan.checks] == [0, 3, 6]
    assert [j.seed for j in plan.copies] == [1, 2, 4, 5]
