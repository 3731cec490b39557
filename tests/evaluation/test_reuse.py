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
    # the check bar (two episodes: the one asked for, dwa3's, and random's first), then the
    # episodes' bar from the one taken and the two checked
    assert [(b.initial, b.n, b.total) for b in bars] == [(0, 2, 2), (3, 4, 4)]
    assert reused(tmp_path / "out")[0]["episodes"] == 1


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


def test_every_method_and_profile_gets_a_check_beside_the_evenly_spaced_ones():
    jobs = [Job(TINY, m, s, n) for m in ("dwa3", "random") for n in ("none", "real", "harsh")
            for s in range(4)]  # fmt: skip
    picks = reuse_module.check_picks(jobs, 1)  # one evenly spaced: the first, dwa3 under none
    assert {(jobs[i].method, jobs[i].noise) for i in picks} >= {("dwa3", "none")}
    assert {jobs[i].method for i in picks} == {"dwa3", "random"}
    assert {jobs[i].noise for i in picks} == {"none", "real", "harsh"}
    assert sorted(picks) == [0, 4, 8, 12]  # dwa3 none, dwa3 real, dwa3 harsh, random none
    assert reuse_module.check_picks([], 3) == set()
