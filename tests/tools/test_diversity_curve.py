"""diversity_curve (issue 56, part 3): success and score against BARN training worlds, and the
reading of the largest count against the smallest, from eval directories written with the
project's own writer (appending_rows, write_meta)."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
from scipy import stats

from d3dwa_bullet.episode_config import EpisodeConfig
from d3dwa_bullet.evaluation.columns import with_recovery
from d3dwa_bullet.evaluation.results import (
    CSV_FIELDS,
    appending_rows,
    row_key,
    write_meta,
)
from d3dwa_bullet.learning.training.config import TrainConfig
from d3dwa_bullet.world.barn import barn_name, barn_split_ids
from tools.experiments import diversity_curve

WORLDS = [barn_name(i) for i in barn_split_ids("challenge")[:6]]
METHOD = "d3dwa-barn"


def value(outcome, seed, world, metric):
    """A synthetic episode's metric: 0 for a failure, else varying with world and seed."""
    if outcome != "goal":
        return 0.0
    return {"success": 1.0, "score": 0.5 + 0.05 * world + 0.01 * seed,
            "score_barn": 0.1 + 0.01 * world}[metric]  # fmt: skip


@functools.cache
def trained_on(k):
    """The config.json of a seed trained on k BARN train worlds (TrainConfig's own dict)."""
    return TrainConfig(method=METHOD, barn_split="train", barn_worlds=k).to_dict()


def eval_dir(path, outcomes, k=None, worlds=WORLDS, noise="none", recovery="nav2", todo=()):
    """A d3dwa eval results directory: seed -> one outcome per world, its meta.json naming a
    --policy folder; with k, that folder's seed-<s>/config.json records barn_worlds k, without
    it the folder is absent."""
    path.mkdir(parents=True)
    settings = {"kind": "eval", "methods": [METHOD], "noise": noise, "recovery": recovery}
    policy = path.parent / f"{path.name}-policy"  # without k: a folder no longer there
    settings["policy"] = str(policy.resolve())
    if k is not None:
        for s in outcomes:
            (policy / f"seed-{s}").mkdir(parents=True)
            config = trained_on(k) | {"seed": s}
            (policy / f"seed-{s}" / "config.json").write_text(json.dumps(config))
    fields = with_recovery(CSV_FIELDS, recovery)
    keys = []
    with appending_rows(path, fields) as append:
        for s, outs in outcomes.items():
            for j, (w, o) in enumerate(zip(worlds, outs, strict=True)):
                row = dict(world=w, method=METHOD, policy_seed=s, seed=0, noise=noise, outcome=o,
                           time_s=30.0, tl_m=11.0, pd_rad=1.0, min_clearance_m=0.1, steps=300,
                           score=value(o, s, j, "score"), score_barn=value(o, s, j, "score_barn"),
                           reference_length_m=11.0, recovery=recovery)  # fmt: skip
                append(row)
                keys.append(row_key(row))
    write_meta(path, EpisodeConfig(), settings, fields, [*keys, *todo])  # todo: jobs not run
    return path


G, T = "goal", "timeout"
FEW = {0: [G, T, T, T, G, T], 1: [T, T, G, T, T, T], 2: [G, G, T, T, T, T]}
MANY = {0: [G, G, G, T, G, G], 1: [G, G, G, G, G, T], 2: [G, G, G, G, G, G], 3: [G, T, G, G, G, G]}


def expected(outcomes, metric):
    """Per-seed means over worlds, their mean and 95 % t interval, computed here from scratch."""
    per = {s: np.mean([value(o, s, j, metric) for j, o in enumerate(outs)])
           for s, outs in outcomes.items()}  # fmt: skip
    x = np.array(list(per.values()))
    low, high = stats.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=stats.sem(x))
    return per, x.mean(), max(low, 0.0), min(high, 1.0)  # every metric lies in [0, 1]


@pytest.fixture
def points(tmp_path):
    return {
        5: eval_dir(tmp_path / "w5", FEW, k=5),
        50: eval_dir(tmp_path / "w50", {s: FEW[s][:3] + [G, G, T] for s in FEW}, k=50),
        250: eval_dir(tmp_path / "w250", MANY, k=250),
    }


def run(points, tmp_path, capsys, *extra):
    out = tmp_path / "fig" / "curve.png"
    argv = [f"{k}={d}" for k, d in points.items()] + ["--out", str(out), "--json", *extra]
    assert diversity_curve.main(argv) == 0
    return json.loads(capsys.readouterr().out), out


def test_each_point_is_its_seeds_mean_with_a_t_interval_and_every_seed_shown(
    points, tmp_path, capsys
):
    curve, out = run(points, tmp_path, capsys)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p["k"] for p in curve["points"]] == [5, 50, 250]
    assert curve["worlds"] == 6 and curve["noise"] == "none" and curve["recovery"] == "nav2"
    by_k = {p["k"]: p for p in curve["points"]}
    assert by_k[250]["seeds"] == [0, 1, 2, 3] and by_k[5]["checked"] == "config.json"
    for k, outcomes in ((5, FEW), (250, MANY)):
        for metric in ("success", "score", "score_barn"):
            per, mean, low, high = expected(outcomes, metric)
            got = by_k[k][metric]
            assert got["mean"] == pytest.approx(mean)
            assert (got["low"], got["high"]) == pytest.approx((low, high))
            assert list(got["seeds"].values()) == pytest.approx(list(per.values()))
    assert by_k[5]["success"]["mean"] == pytest.approx(5 / 18)  # 2 + 1 + 2 of 6 worlds
    assert by_k[250]["success"]["high"] == 1.0  # t reaches past 100 %: cut at the edge


def test_the_largest_count_against_the_smallest_is_read_paired_by_world(points, tmp_path, capsys):
    curve, _ = run(points, tmp_path, capsys)
    assert (curve["a"], curve["b"]) == (250, 5)
    for metric in ("success", "score"):
        a = np.array(
            [np.mean([value(o[j], s, j, metric) for s, o in MANY.items()]) for j in range(6)]
        )
        b = np.array(
            [np.mean([value(o[j], s, j, metric) for s, o in FEW.items()]) for j in range(6)]
        )
        test = stats.ttest_1samp(a - b, 0.0, alternative="greater")
        r = curve["reading"][metric]
        assert r["layouts"] == 6 and r["difference"] == pytest.approx((a - b).mean())
        assert r["p_a_better"] == pytest.approx(test.pvalue)
        assert r["reading"] == ("A better" if test.pvalue < 0.025 else r["reading"])
    assert curve["reading"]["success"]["reading"] == "A better"
    assert curve["reading"]["success"]["margin"] == 0.03  # compare's default
    assert curve["answer"].startswith(
        "Do more training worlds buy success here? Yes: 250 against 5"
    )


def test_the_same_curve_at_both_ends_reads_equivalent_and_answers_no(tmp_path, capsys):
    same = {5: eval_dir(tmp_path / "a", FEW, k=5), 250: eval_dir(tmp_path / "b", FEW, k=250)}
    curve, _ = run(same, tmp_path, capsys, "--margin-success", "5")
    r = curve["reading"]["success"]
    assert r["reading"] == "equivalent" and r["difference"] == 0.0 and r["margin"] == 0.05
    assert "? No: 250 against 5 worlds, success: equivalent within ±5 points" in curve["answer"]


def test_the_table_holds_every_point_and_the_reading(points, tmp_path, capsys):
    table = tmp_path / "curve.md"
    out = tmp_path / "c.png"
    argv = [f"{k}={d}" for k, d in points.items()] + ["--out", str(out), "--table", str(table)]
    assert diversity_curve.main(argv) == 0
    text = table.read_text()
    assert text in capsys.readouterr().out
    _, mean, low, high = expected(FEW, "success")
    assert (
        f"| 5 | 0, 1, 2 | config.json | {100 * mean:.1f} [{100 * low:.1f}, {100 * high:.1f}] |"
        in text
    )
    assert "| A = 250 worlds, B = 5 worlds | success (±3 points) | 6 |" in text
    assert all(len(line) <= 400 for line in text.splitlines())


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda p: {5: eval_dir(p / "a", FEW, k=5), 50: eval_dir(p / "b", FEW, k=5)},
            "barn_worlds is 5, but the point says K=50",
        ),
        (
            lambda p: {
                5: eval_dir(p / "a", FEW, k=5),
                50: eval_dir(p / "b", {0: FEW[0], 1: FEW[1]}, k=50),
            },
            "2 training seeds of 'd3dwa-barn' (seed-0, seed-1); a point of the curve needs 3",
        ),
        (
            lambda p: {
                5: eval_dir(p / "a", FEW),
                50: eval_dir(p / "b", FEW, worlds=WORLDS[1:] + ["BARN-1"]),
            },
            "world BARN-1 is not in BARN's challenge split",
        ),
        (
            lambda p: {5: eval_dir(p / "a", FEW), 50: eval_dir(p / "b", FEW, noise="harsh")},
            "differ in noise: harsh vs none",
        ),
        (
            lambda p: {
                5: eval_dir(p / "a", FEW),
                50: eval_dir(p / "b", FEW, worlds=WORLDS[1:] + [barn_name(36)]),
            },
            "differ in worlds: 6 worlds vs 6 worlds (not the same ones)",
        ),
        (
            lambda p: {
                5: eval_dir(p / "a", FEW),
                50: eval_dir(p / "b", FEW, todo=[(barn_name(36), METHOD, 0, 0, "none")]),
            },
            "18 of its 19 episodes are in: the evaluation is incomplete",
        ),
        (lambda p: {5: eval_dir(p / "a", FEW)}, "a curve needs two points or more"),
        (lambda p: {5: eval_dir(p / "a", FEW), 50: p / "nowhere"}, "no results.csv"),
    ],  # fmt: skip
)
def test_a_point_that_is_not_one_is_refused_in_one_line(tmp_path, capsys, make, message):
    points = make(tmp_path)
    out = tmp_path / "c.png"
    assert diversity_curve.main([f"{k}={d}" for k, d in points.items()] + ["--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("diversity_curve: error: ") and len(err.splitlines()) == 1
    assert message in err
    assert not out.exists()


def test_a_count_without_policies_to_check_it_against_is_said_unchecked(tmp_path, capsys):
    points = {5: eval_dir(tmp_path / "a", FEW), 250: eval_dir(tmp_path / "b", MANY, k=250)}
    curve, _ = run(points, tmp_path, capsys)
    first, last = curve["points"]
    assert first["checked"].startswith("unchecked (3 of 3 seeds without a config.json in ")
    assert last["checked"] == "config.json"


def test_a_policy_not_trained_on_barn_is_refused(tmp_path, capsys):
    a, b = eval_dir(tmp_path / "a", FEW, k=5), eval_dir(tmp_path / "b", FEW, k=50)
    config = tmp_path / "b-policy" / "seed-1" / "config.json"
    config.write_text(json.dumps(TrainConfig(method="d3dwa").to_dict()))
    assert diversity_curve.main([f"5={a}", f"50={b}", "--out", str(tmp_path / "c.png")]) == 2
    err = capsys.readouterr().err
    assert str(config) in err and "barn_split is 'none'" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["5x=d", "6=e"], "is not K=EVALDIR"),
        (["251=d", "5=e"], "K must be in [1, 250]"),
        (["5=d", "5=e"], "point K=5 is given twice"),
        (["5=d", "50=e", "--margin-success", "0"], "--margin-success must be a positive"),
        (["--train-seeds", "2-0", "--commands"], "--train-seeds"),
    ],
)
def test_bad_options_are_one_line(tmp_path, capsys, argv, message):
    assert diversity_curve.main([*argv, "--out", str(tmp_path / "c.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert diversity_curve.main(["5=d", "50=e", "--out", str(tmp_path / "c.svg")]) == 2
    assert ".png" in capsys.readouterr().err


def test_the_printed_commands_evaluate_what_they_train_and_draw_what_they_evaluate(capsys):
    assert diversity_curve.main(["--commands", "--train-seeds", "0-3"]) == 0
    lines = capsys.readouterr().out.splitlines()
    train = [line.split() for line in lines if line.startswith("d3dwa train")]
    evals = [line.split() for line in lines if line.startswith("d3dwa eval")]
    last = lines[-1].split()
    assert len(train) == len(evals) == 3 and last[:3] == [
        "python",
        "-m",
        "tools.experiments.diversity_curve",
    ]

    def opt(words, name):
        return words[words.index(name) + 1]

    assert [opt(t, "--barn-worlds") for t in train[:2]] == [
        "5",
        "50",
    ] and "--barn-worlds" not in train[2]
    assert [opt(t, "--seeds") for t in train[:2]] == ["0-3", "0-3"]
    assert [opt(e, "--policy") for e in evals] == [opt(t, "--out") for t in train]
    assert all(opt(e, "--split") == "challenge" and opt(e, "--methods") == METHOD for e in evals)
    assert last[3:6] == [f"{k}={opt(e, '--out')}" for k, e in zip((5, 50, 250), evals, strict=True)]
