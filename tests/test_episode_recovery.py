"""The recovery layer inside the episode loop: off changes nothing, on it logs its steps,
escapes a stall the paper's stack times out in, never touches an obstacle, and repeats."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import Episode, EpisodeConfig, run_episode
from d3dwa_bullet.evaluation.failures import recoveries
from d3dwa_bullet.params import RecoveryParams
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import load_world

NAV2 = EpisodeConfig(recovery=RecoveryParams())


def test_without_recovery_the_log_marks_no_recovery_and_the_row_has_no_column(post_world):
    res = run_episode(post_world, make_controller("dwa3"))
    assert (res.log["recovery"] == 0).all() and "recovery" not in res.summary()
    assert recoveries(res.log) == (0, 0)


def test_recovery_escapes_a_stall_that_times_out_without_it():
    # DWA III stands still beside the goal side of H2's doorway (docs/history.md#recovery); the
    # recovery layer's spin turns it free. Also: the same seed gives the same episode.
    world = load_world("H2")
    paper = run_episode(world, make_controller("dwa3"))
    first = run_episode(world, make_controller("dwa3"), config=NAV2)
    again = run_episode(world, make_controller("dwa3"), config=NAV2)
    assert paper.outcome == "timeout"
    assert first.outcome == "goal" and first.summary()["recovery"] == "nav2"
    codes = first.log["recovery"]
    assert (codes > 0).any() and set(np.unique(codes)) <= {0, 1, 2}
    # the robot stood still for the whole progress window before the first recovery step
    start = int(np.flatnonzero(codes > 0)[0])
    window = int(RecoveryParams().window / 0.1)
    x, y = first.log["est_x"], first.log["est_y"]
    assert np.hypot(x[start] - x[start - window], y[start] - y[start - window]) < 0.5
    started, progressed = recoveries(first.log)
    assert started >= 1 and progressed >= 1
    assert first.summary() == again.summary()
    for k in first.log:
        assert np.array_equal(first.log[k], again.log[k])


@pytest.mark.parametrize("name", ["US1", "TS4"])
def test_recovery_motions_never_touch_an_obstacle(name):
    world = load_world(name)
    controller = make_controller("dwa3")
    touched, recovering = [], 0
    with Episode(world, config=NAV2) as ep:
        while True:
            obs = ep.observe()
            if ep.outcome is not None:
                break
            ep.act(*controller(obs))
            if ep.last_recovery is not None:
                recovering += 1
                touched.append(ep.sim.in_contact())
    assert recovering > 0  # these two do stall, so the layer did act
    assert not any(touched) and ep.outcome != "collision"


def test_recovery_steps_override_the_action():
    # Goal behind the robot and a short window: it loops round within 0.5 m of where it
    # was and the layer spins it while the action says drive; its command, not the planner's, is what the log holds on those steps.
    world = World("behind", "goal behind", (0.0, 0.0, 0.0), (-0.5, 0.0), ()).with_task(
        time_limit=15.0
    )
    config = EpisodeConfig(recovery=RecoveryParams(window=2.0))
    res = run_episode(world, make_controller("dwa3"), config=config)
    spins = res.log["recovery"] == 1
    assert spins.any()
    # turning in place, then stop commands until the robot is at rest
    w = np.abs(res.log["w_cmd"][spins])
    assert np.allclose(res.log["v_cmd"][spins], 0.0) and (w > 0).sum() >= 5
    assert (w[w < 1e-12] == 0.0).all() and (w == 0.0).any()
