"""Issue 40 part 1's instruments: one noise source removed or alone, the headroom switch, storms."""

from __future__ import annotations

import json

import numpy as np
import pytest

from randomization import load_profile
from tests.evaluation.test_failures import log
from tests.support.results_logs import write_results
from tools.experiments import headroom, noise_sources, regime_probe
from tools.experiments.storm_steps import storm_onsets, summarise


def test_each_source_is_removed_from_harsh_and_alone_over_none(tmp_path):
    paths = noise_sources.write("harsh", "none", tmp_path)
    assert len(paths) == 2 * len(noise_sources.SOURCES)
    harsh, none = load_profile("harsh"), load_profile("none")
    no_slip = load_profile(tmp_path / "harsh-no-slip.yaml")
    only_range = load_profile(tmp_path / "harsh-only-lidar_range.yaml")
    rng = np.random.default_rng(0)
    cfg = no_slip.sample(rng)
    assert cfg.slip.level_mean == 0.0 and cfg.slip.step_std == 0.0
    assert cfg.lidar.spurious_prob >= 0.005  # the rest stays at harsh
    cfg = only_range.sample(np.random.default_rng(0))
    assert 0.02 <= cfg.lidar.range_std <= 0.05
    assert cfg.lidar.dropout_prob == 0.0 and cfg.slip.level_mean == 0.0
    assert none.sample(rng).lidar.range_std == 0.0 and harsh.name == "harsh"


def test_a_lidar_source_takes_only_its_own_fields(tmp_path):
    profiles = noise_sources.split_profiles("harsh", "none")
    spurious = profiles["harsh-only-lidar_spurious"]["params"]["lidar"]
    assert spurious["spurious_prob"] == {"uniform": [0.005, 0.01]}
    assert spurious["range_std"] == 0.0 and spurious["dropout_prob"] == 0.0


def sweep_dir(tmp_path, rows):
    return write_results(tmp_path, ((r, log(speed=0.0, outcome=r["outcome"])) for r in rows))


def rows_for(method, noise, outcomes, policy_seed=""):
    axis = "none" if noise == "none" else "profile"
    return [dict(world=f"L{i}", method=method, policy_seed=policy_seed, seed=0, noise=noise,
                 axis=axis, outcome=o) for i, o in enumerate(outcomes)]  # fmt: skip


def test_headroom_plays_the_method_each_profile_names(tmp_path, capsys):
    rows = rows_for("dwa3", "none", ["goal", "timeout"]) + rows_for("dwa3", "harsh", ["goal"] * 2)
    rows += rows_for("d3dwa", "none", ["goal", "goal"], 0)
    rows += rows_for("d3dwa", "none", ["goal", "timeout"], 1)
    rows += rows_for("d3dwa", "harsh", ["timeout", "timeout"], 0)
    rows += rows_for("d3dwa", "harsh", ["goal", "timeout"], 1)
    out = sweep_dir(tmp_path, rows)
    records = headroom.headroom(out, {"none": "d3dwa", "harsh": "dwa3"})
    assert records[0]["headroom"]["success"] == pytest.approx(0.75)
    assert records[1]["headroom"]["success"] == 1.0
    assert records[1]["methods"]["d3dwa"]["success"] == pytest.approx(0.25)
    assert records[1]["best_fixed"] == "dwa3"
    assert headroom.main([str(out), "--switch", "none=d3dwa,harsh=dwa1"]) == 2
    assert "no rows of 'dwa1' under profile 'harsh'" in capsys.readouterr().err
    assert headroom.main([str(out), "--switch", "harsh"]) == 2
    assert "'harsh' is not PROFILE=METHOD" in capsys.readouterr().err


def test_the_paired_headroom_tests_the_switch_against_every_method(tmp_path, capsys):
    wins = ["goal"] * 6
    rows = rows_for("dwa3", "harsh", wins) + rows_for("random@10", "harsh", ["timeout"] * 6)
    rows += rows_for("d3dwa", "harsh", ["goal", "timeout"] * 3, 0)
    out = sweep_dir(tmp_path / "a", rows)
    other = sweep_dir(tmp_path / "b", rows_for("d3dwa-dr", "harsh", wins[:5] + ["timeout"], 0))
    records = {r["method"]: r for r in headroom.paired([out, other], {"harsh": "dwa3"})}
    assert records["dwa3"]["p"] == 0.5 and records["dwa3"]["paired_p"] == 1.0  # itself
    # six layouts each won by the switch: the one-sided signed-rank p is 1/2^6
    assert records["random@10"]["paired_p"] == pytest.approx(1 / 64)
    assert records["random@10"]["p"] == 1.0 and records["random@10"]["paired_wins"] == 6
    assert records["d3dwa"]["paired_wins"] == 3 and records["d3dwa"]["paired_losses"] == 0
    assert records["d3dwa-dr"]["paired_wins"] == 1  # from the second sweep
    assert headroom.main([str(out), "--switch", "harsh=dwa3", "--paired", "--also", str(out)]) == 2
    assert "method 'dwa3' is also in" in capsys.readouterr().err
    assert headroom.main([str(out), "--pair-by", "layout"]) == 2
    assert "--pair-by needs --paired" in capsys.readouterr().err


def test_the_paired_headroom_can_pool_evaluation_seeds_per_layout(tmp_path):
    # two evaluation seeds per layout: 12 units by (layout, seed), 6 by layout
    rows = rows_for("dwa3", "harsh", ["goal"] * 6) + rows_for("random@10", "harsh", ["timeout"] * 6)
    rows += [r | {"seed": 1} for r in rows]
    out = sweep_dir(tmp_path, rows)
    by_seed = {r["method"]: r for r in headroom.paired([out], {"harsh": "dwa3"})}
    by_layout = {r["method"]: r for r in headroom.paired([out], {"harsh": "dwa3"}, by_seed=False)}
    assert by_seed["random@10"]["paired_units"] == 12
    assert by_seed["random@10"]["paired_p"] == pytest.approx(1 / 2**12)
    assert by_layout["random@10"]["paired_units"] == 6
    assert by_layout["random@10"]["paired_p"] == pytest.approx(1 / 2**6)


def test_the_sources_table_reads_each_condition_against_its_reference(tmp_path, capsys):
    rows = rows_for("dwa3", "none", ["goal", "goal"]) + rows_for("dwa3", "harsh", ["goal", "x"])
    rows += rows_for("dwa3", "p/harsh-no-slip.yaml", ["goal", "goal"])
    rows += rows_for("dwa3", "p/harsh-only-slip.yaml", ["timeout", "goal"])
    for r in rows:
        r["outcome"] = "timeout" if r["outcome"] == "x" else r["outcome"]
    out = sweep_dir(tmp_path, rows)
    assert noise_sources.main(["table", str(out), "--json"]) == 0
    recs = {r["condition"]: r for r in json.loads(capsys.readouterr().out)}
    assert recs["harsh-no-slip"]["success"] == 1.0 and recs["harsh"]["success"] == 0.5
    table = noise_sources.markdown(list(recs.values()))
    assert "| harsh-no-slip | 100 (+50; 0) |" in table  # against harsh
    assert "| harsh-only-slip | 50 (-50; 0) |" in table  # against none


def test_storm_onsets_and_windows():
    fallback = np.array([0, 1, 1, 1, 1, 1, 0, 1, 1, 0] + [0] * 30 + [1] * 6, dtype=float)
    assert storm_onsets(fallback) == [1, 40]
    n = len(fallback)
    steps = dict(fallback=fallback, planned=np.ones(n), admissible=np.where(fallback, 0.0, 9.0),
                 tau=np.full(n, 4.0), wp=np.ones(n), phantom=np.zeros(n),
                 scan_min=np.ones(n), true_min=np.ones(n))  # fmt: skip
    s = summarise([steps])
    assert s["storms"] == 2 and s["all"]["steps"] == n
    assert s["before_storm"]["steps"] == 1 + 30  # step 0, then steps 10-39 before the second
    assert s["fallback_steps"]["admissible"] == 0.0


def test_the_regime_probe_tells_two_regimes_apart_only_where_the_inputs_differ(tmp_path):
    rng = np.random.default_rng(0)

    def episode(noisy: bool) -> dict:
        obs = rng.uniform(0.3, 1.0, (60, 12))
        if noisy:  # a regime that shows in one observation: a short sector now and then
            obs[::2, 5] = 0.05
        return {"observations": obs, "tau": np.full(60, 4.0)}

    data = {f"L{i}": [episode(False), episode(True)] for i in range(6)}
    windows = {w: [regime_probe.windows(e, 3, 1) for e in per] for w, per in data.items()}
    assert windows["L0"][0].shape == (58, 3 * 13)
    one = regime_probe.accuracy(windows, 13, epochs=20)
    assert 0.55 < one["accuracy"] < 0.75  # half the noisy steps look clean: at most 0.75
    history = regime_probe.accuracy(windows, 3 * 13, epochs=20)
    assert history["accuracy"] > one["accuracy"] + 0.1  # every window of three shows it
