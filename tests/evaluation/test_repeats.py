"""Without noise a fixed method or a greedy policy repeats its episode at every evaluation seed:
eval and sweep run it once per layout and every reader counts it once; a directory written
before, which holds the repeats, reads the same, resumes without rerunning, and its tables
and paired tests give the numbers the repeated rows gave."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation import jobs as evaluation
from d3dwa_bullet.evaluation.jobs import Job, evaluate
from d3dwa_bullet.evaluation.paired import paired_scores, paired_test
from d3dwa_bullet.evaluation.readings import readings_by_group
from d3dwa_bullet.evaluation.repeats import kept_keys, repeats_at_every_seed
from d3dwa_bullet.evaluation.report import eval_markdown
from d3dwa_bullet.evaluation.results import (
    completion,
    job_rows,
    once_per_layout,
    read_meta,
    read_results,
    row_key,
)
from d3dwa_bullet.evaluation.seed_tables import improvement
from d3dwa_bullet.evaluation.sweep import run_sweep
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.params import RecoveryParams
from d3dwa_bullet.world.model import Box, World
from d3dwa_bullet.world.registry import load_world


def test_only_fixed_and_learned_methods_without_noise_repeat():
    for method in ("dwa1", "dwa3", "d3dwa", "d3dwa-weights", "dqdwa", "d3dwa-history-dr"):
        assert repeats_at_every_seed(method, "none")
        assert not repeats_at_every_seed(method, "real")
        assert not repeats_at_every_seed(method, "slip=0.1")
    for method in ("random", "random-weights", "random@10", "random-weights@5", "external"):
        assert not repeats_at_every_seed(method, "none")
    keys = [("W", m, p, s, "none") for m, p in (("dwa3", None), ("d3dwa", 0)) for s in (2, 1, 3)]
    keys += [("W", "random", None, s, "none") for s in (1, 2)]
    assert kept_keys(keys) == [
        ("W", "dwa3", None, 1, "none"),
        ("W", "d3dwa", 0, 1, "none"),
        ("W", "random", None, 1, "none"),
        ("W", "random", None, 2, "none"),
    ]


def test_the_layer_and_the_scan_filter_draw_nothing_from_the_episode_seed():
    # A wall across the way: DWA III stalls, the recovery layer acts, behind the filters.
    wall = World(
        name="wall", description="a wall across the way", start=(0.0, 0.0, 0.0),
        goal=(2.0, 0.0), time_limit=8.0, obstacles=(Box(center=(0.8, 0.0), size=(0.1, 1.6)),),
    )  # fmt: skip
    config = EpisodeConfig(recovery=RecoveryParams(window=1.0), scan_filter="speckle+median")
    logs = [evaluation.run_job(Job(wall, "dwa3", seed), config).log for seed in (0, 7)]
    assert (logs[0]["recovery"] > 0).any()
    for k in logs[0]:
        assert np.array_equal(logs[0][k], logs[1][k]), k


def jobs_of(world: World, methods, seeds=(0, 1, 2), noise="none") -> list[Job]:
    return [Job(world, m, s, noise) for m in methods for s in seeds]


def test_eval_runs_a_deterministic_method_once_per_layout_and_a_random_one_every_seed(
    one_second_world, tmp_path
):
    world = load_world(one_second_world)
    rows = evaluate(jobs_of(world, ("dwa3", "random")), tmp_path, progress=False)
    assert [(r["method"], r["seed"]) for r in rows] == [
        ("dwa3", 0), ("random", 0), ("random", 1), ("random", 2),
    ]  # fmt: skip
    assert len(read_results(tmp_path)) == 4 and len(list((tmp_path / "logs").iterdir())) == 4
    assert completion(tmp_path) == (4, 4) and len(read_meta(tmp_path)["jobs"]) == 4
    page = eval_markdown(rows, ["dwa3", "random"], [world.name], [0, 1, 2], "none")
    assert "Deterministic without noise: run once per layout" in page
    noisy = evaluate(jobs_of(world, ("dwa3",), noise="real"), tmp_path / "real", progress=False)
    assert [r["seed"] for r in noisy] == [0, 1, 2]  # with noise every seed is its own episode


def old_style(jobs, out, monkeypatch):
    """A directory as eval wrote it before the rule: every seed of every job run."""
    with monkeypatch.context() as m:
        m.setattr(evaluation, "kept_keys", list)
        return evaluate(jobs, out, progress=False)


def test_a_directory_with_the_repeats_reads_the_same_and_resumes_without_rerunning(
    one_second_world, tmp_path, monkeypatch
):
    world = load_world(one_second_world)
    jobs = jobs_of(world, ("dwa3", "random"))
    old = old_style(jobs, tmp_path / "old", monkeypatch)
    assert len(old) == 6 and len(read_results(tmp_path / "old")) == 6
    assert old[0]["outcome"] == old[1]["outcome"] and old[0]["time_s"] == old[1]["time_s"]
    new = evaluate(jobs, tmp_path / "new", progress=False)

    def same(rows):
        return [{k: v for k, v in r.items()} for r in rows]

    assert same(job_rows(tmp_path / "old")) == same(new) == same(once_per_layout(old))
    assert completion(tmp_path / "old") == (4, 4)

    def no_episode(*args):
        raise AssertionError("an episode ran on resume")

    monkeypatch.setattr(evaluation, "_worker", no_episode)
    assert same(evaluate(jobs, tmp_path / "old", progress=False)) == same(new)
    assert len(read_meta(tmp_path / "old")["jobs"]) == 4  # the resumed run lists each once
    assert same(evaluate(jobs, tmp_path / "new", progress=False)) == same(new)
    page = eval_markdown(new, ["dwa3", "random"], [world.name], [0, 1, 2], "none")
    assert eval_markdown(job_rows(tmp_path / "old"), ["dwa3", "random"], [world.name],
                         [0, 1, 2], "none") == page  # fmt: skip


def test_a_sweep_runs_its_noise_free_cells_once(one_second_world, tmp_path):
    settings = SweepSettings(methods=("dwa3", "random"), worlds=(one_second_world,), styles=(),
                             layouts=0, seeds=2, levels=1, axes=("slip",),
                             profiles=("none",))  # fmt: skip
    rows, complete = run_sweep(settings, tmp_path, progress=False, figures=False)
    got = sorted((r["method"], r["noise"], r["seed"]) for r in rows)
    assert complete and got == [
        ("dwa3", "none", 0), ("dwa3", "slip=0.4", 0), ("dwa3", "slip=0.4", 1),
        ("random", "none", 0), ("random", "none", 1),
        ("random", "slip=0.4", 0), ("random", "slip=0.4", 1),
    ]  # fmt: skip
    assert "Deterministic without noise: run once per layout" in (tmp_path / "sweep.md").read_text()


def test_a_sweep_with_the_repeats_resumes_without_rerunning(
    one_second_world, tmp_path, monkeypatch
):
    settings = SweepSettings(methods=("dwa3", "random"), worlds=(one_second_world,), styles=(),
                             layouts=0, seeds=2, levels=1, axes=(), profiles=("none",))  # fmt: skip
    with monkeypatch.context() as m:
        m.setattr(evaluation, "kept_keys", list)
        run_sweep(settings, tmp_path, progress=False, figures=False)
    assert len(read_results(tmp_path)) == 4  # before the rule: DWA III at both seeds

    def no_episode(*args):
        raise AssertionError("an episode ran on resume")

    monkeypatch.setattr(evaluation, "_worker", no_episode)
    rows, complete = run_sweep(settings, tmp_path, progress=False, figures=False)
    assert complete and sorted((r["method"], r["seed"]) for r in rows) == [
        ("dwa3", 0), ("random", 0), ("random", 1),
    ]  # fmt: skip
    page = (tmp_path / "sweep.md").read_text()  # one-second episodes: every one a timeout
    assert "| DWA III (2,1,1) | given | 0/1; 0.00 |" in page  # its layout counted once
    assert "| Random (uniform over 100 actions) | given | 0/2; 0.00 |" in page


LAYOUTS = [f"L{k}" for k in range(6)]
SEEDS = (0, 1, 2)
# a greedy policy's three training seeds: one outcome per layout, the same at every seed
LEARNED = {(w, t): (k + t) % 3 != 0 for k, w in enumerate(LAYOUTS) for t in range(3)}
FIXED = {w: k % 2 == 0 for k, w in enumerate(LAYOUTS)}
RANDOM = {(w, s): (k * 5 + s) % 4 < 2 for k, w in enumerate(LAYOUTS) for s in SEEDS}


def row(method, world, seed, goal, policy_seed=None):
    return {"world": world, "method": method, "policy_seed": policy_seed, "seed": seed,
            "noise": "none", "outcome": "goal" if goal else "timeout", "time_s": 5.0,
            "score": 0.5 * goal, "score_barn": 0.1 * goal}  # fmt: skip


def repeated_rows() -> list[dict]:
    """Rows as a 3-seed run wrote them before the rule: the repeats at every seed."""
    rows = [row("d3dwa", w, s, g, t) for (w, t), g in LEARNED.items() for s in SEEDS]
    rows += [row("dwa3", w, s, g) for w, g in FIXED.items() for s in SEEDS]
    return rows + [row("random", w, s, g) for (w, s), g in RANDOM.items()]


@pytest.mark.parametrize("a", ["d3dwa", "dwa3"])
def test_paired_tests_and_readings_give_what_the_repeated_rows_gave(a):
    old = repeated_rows()
    once = once_per_layout(old)
    assert len(once) == len(old) - 2 * (len(LEARNED) + len(FIXED))
    # by (layout, seed): the one episode stands at each of the random chooser's seeds
    scores = paired_scores(once, a, "random")
    value = {w: np.mean([LEARNED[(w, t)] for t in range(3)]) if a == "d3dwa" else FIXED[w]
             for w in LAYOUTS}  # fmt: skip
    assert scores == {(w, "none", s): (value[w], float(RANDOM[(w, s)]))
                      for w in LAYOUTS for s in SEEDS}  # fmt: skip
    assert scores == paired_scores(old, a, "random")
    assert paired_test(scores) == paired_test(paired_scores(old, a, "random"))
    # by layout: one side's one episode against the other's three, averaged per layout
    pooled = paired_scores(once, a, "random", by_seed=False)
    assert pooled == {(w, "none", None): (value[w], np.mean([RANDOM[(w, s)] for s in SEEDS]))
                      for w in LAYOUTS}  # fmt: skip
    groups = {(w, "none", None): [] for w in LAYOUTS}
    margins = {"success": 0.05, "score": 0.02}
    assert readings_by_group(once, a, "random", groups, margins) == readings_by_group(
        old, a, "random", groups, margins
    )
    # P(A > B): the fixed method's one run, or the repeats of it, give one interval
    for new, before in zip(improvement(once, a, "random", lambda r: []),
                           improvement(old, a, "random", lambda r: []), strict=True):  # fmt: skip
        assert (new["p"], new["low"], new["high"]) == (before["p"], before["low"], before["high"])


def test_two_deterministic_sides_pair_once_per_layout():
    once = once_per_layout(repeated_rows())
    scores = paired_scores(once, "d3dwa", "dwa3")
    assert sorted(scores) == [(w, "none", 0) for w in LAYOUTS]
    assert {row_key(r)[3] for r in once if r["method"] != "random"} == {0}
