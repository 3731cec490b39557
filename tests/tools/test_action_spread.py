"""The action-spread diagnostic: the effective number of tuples a policy uses, and a tuple's share."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from tests.support.held_policy import held_checkpoint
from tests.support.results_logs import write_results
from tools.experiments import action_spread


def sweep_with_tuples(tmp_path, episodes, extra=None):
    """A results directory whose episodes (method, policy seed, [(wp, wc, ws, tau), ...]) hold
    each listed tuple for one step; extra: more arrays for every log."""

    def episode(i, method, seed, tuples):
        row = dict(world=f"L{i}", method=method, policy_seed=seed, noise="harsh", steps=len(tuples))
        cols = np.array(tuples, dtype=float).T
        arrays = dict(wp=cols[0], wc=cols[1], ws=cols[2], tau=cols[3], outcome="goal")
        return row, arrays | (extra or {})

    return write_results(tmp_path, (episode(i, *e) for i, e in enumerate(episodes)))


def test_perplexity_counts_the_effective_tuples():
    one = action_spread.Counter({(1.0, 1.0, 1.0, 2.0): 7})
    assert action_spread.perplexity(one) == pytest.approx(1.0)
    even = action_spread.Counter({(float(k), 1.0, 1.0, 2.0): 3 for k in range(4)})
    assert action_spread.perplexity(even) == pytest.approx(4.0)


def test_spread_per_seed_and_the_reference_share(tmp_path, capsys):
    dwa3 = (2.0, 1.0, 1.0, 4.0)
    other = (1.0, 2.0, 1.0, 3.0)
    out = sweep_with_tuples(tmp_path, [
        ("d3dwa", "0", [dwa3, other, other, other]),
        ("d3dwa", "1", [other] * 4),
        ("dwa3", "", [dwa3] * 3),
    ])  # fmt: skip
    ref = action_spread.reference_tuple("dwa3")
    assert ref == dwa3
    recs = {
        (r["method"], r["policy_seed"]): r
        for r in action_spread.spread(out, ["d3dwa", "dwa3"], ref)
    }
    assert recs[("d3dwa", 0)]["reference_share"] == 0.25 and recs[("d3dwa", 0)]["tuples"] == 2
    assert recs[("d3dwa", 1)]["perplexity"] == pytest.approx(1.0)
    assert recs[("dwa3", None)]["reference_share"] == 1.0
    assert action_spread.main([str(out), "--methods", "d3dwa", "--tuple", "dwa9"]) == 2
    assert "'dwa9' is not a fixed method" in capsys.readouterr().err
    assert action_spread.main([str(out), "--methods", "random"]) == 2
    assert "no episodes of random" in capsys.readouterr().err


def test_margins_read_the_network_at_each_decision_step(tmp_path, capsys):
    folder = held_checkpoint(tmp_path / "pol" / "seed-0", decision_steps=2)
    agent, _ = load_checkpoint(folder)
    obs = np.random.default_rng(0).uniform(0.0, 1.0, (6, 12)).astype(np.float32)
    q = agent.q_values(obs)
    chosen = np.repeat(q[::2].argmax(axis=1), 2)  # decided at steps 0, 2, 4 and held
    chosen[1] = (chosen[1] + 1) % 100  # not a decision step: never read
    tuples = [tuple(ACTIONS_FULL.decode(int(a))) for a in chosen]
    out = sweep_with_tuples(tmp_path / "sweep", [("d3dwa", "0", tuples)],
                            {"observations": obs, "action": chosen})  # fmt: skip
    (rec,) = action_spread.spread(out, ["d3dwa"], (2.0, 1.0, 1.0, 4.0), tmp_path / "pol")
    top = np.sort(q[::2], axis=1)
    assert rec["decisions"] == 3 and rec["argmax_is_logged"] == 1.0
    assert rec["best_minus_second"] == pytest.approx(
        float(np.median(top[:, -1] - top[:, -2])), rel=1e-5
    )
    dwa3 = ACTIONS_FULL.encode((2.0, 1.0, 1.0, 4.0))
    assert rec["best_minus_reference"] == pytest.approx(
        float(np.median(top[:, -1] - q[::2, dwa3])), rel=1e-5
    )
    assert (
        action_spread.main([str(out), "--methods", "d3dwa,dwa3", "--policy", str(tmp_path / "pol")])
        == 2
    )
    assert "--policy reads one method's seeds" in capsys.readouterr().err
    assert action_spread.main([str(out), "--methods", "d3dwa", "--policy", str(tmp_path)]) == 2
    assert "no seed-<k> folders" in capsys.readouterr().err


def test_margins_of_a_tabular_policy_read_its_table_at_the_discretised_state(tmp_path):
    from d3dwa_bullet.learning.agents.policy import all_q_values
    from d3dwa_bullet.planning.actions import ActionSet

    tables = default_policy_path("dqdwa")  # the shipped DQDWA seeds, deciding every 10 steps
    agent, meta = load_checkpoint(tables / "seed-0")
    actions = ActionSet.from_dict(meta["actions"])
    obs = np.random.default_rng(1).uniform(0.0, 3.0, (30, 12)).astype(np.float32)
    q = all_q_values(agent, obs)
    assert q.shape == (30, 25)
    state = agent.discretisation.state_index(obs[10])
    assert np.array_equal(q[10], agent.table[state])  # the table's row for that state
    chosen = np.repeat(q[::10].argmax(axis=1), 10)
    tuples = [tuple(actions.decode(int(a))) for a in chosen]
    out = sweep_with_tuples(tmp_path, [("dqdwa", "0", tuples)],
                            {"observations": obs, "action": chosen})  # fmt: skip
    (rec,) = action_spread.spread(out, ["dqdwa"], (2.0, 1.0, 1.0, 4.0), tables)
    top = np.sort(q[::10], axis=1)
    assert rec["decisions"] == 3 and rec["argmax_is_logged"] == 1.0
    assert rec["best_minus_second"] == pytest.approx(float(np.median(top[:, -1] - top[:, -2])))
    dwa3 = actions.encode((2.0, 1.0, 1.0, 4.0))
    assert rec["best_minus_reference"] == pytest.approx(
        float(np.median(top[:, -1] - q[::10, dwa3]))
    )
