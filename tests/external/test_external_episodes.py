"""A method from outside the package runs the very episode a built-in one does, cannot reach
the episode's state through its inputs, and is refused when it answers wrongly
(docs/design/external-methods.md#external-methods)."""

from __future__ import annotations

import numpy as np
import pytest

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, run_episode
from d3dwa_bullet.errors import ExternalMethodError
from d3dwa_bullet.external.guard import ExternalController
from d3dwa_bullet.params import TerminationParams
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.world.registry import load_world
from tests.support import external_methods

HERE = "tests.support.external_methods"
SHORT = EpisodeConfig(termination=TerminationParams(time_limit=6.0))


def same_episode(a, b) -> None:
    """The same episode, bit for bit: every metric, log column and observation."""
    apart = ("method", "method_source", "overruns")
    assert {k: v for k, v in a.summary().items() if k not in apart} == {
        k: v for k, v in b.summary().items() if k not in apart
    }
    assert a.log.keys() == b.log.keys()
    for key in a.log:
        np.testing.assert_array_equal(a.log[key], b.log[key], err_msg=key)
    np.testing.assert_array_equal(a.observations, b.observations)


@pytest.mark.parametrize(
    ("builtin", "external"),
    [
        ("random", "BuiltinChooser"),
        ("random@10", "HeldRandom"),
        pytest.param(
            "d3dwa", "LearnedD3DWA",
            marks=pytest.mark.skipif(
                not (policies_dir() / "d3dwa").exists(), reason="no shipped d3dwa policy"
            ),
        ),
    ],
)  # fmt: skip
def test_a_builtin_through_the_interface_runs_the_same_episode(builtin, external):
    world = load_world("R1")
    ours = run_episode(world, make_controller(builtin), seed=3, config=SHORT)
    theirs_controller = make_controller(f"{HERE}:{external}")
    assert isinstance(theirs_controller, ExternalController)
    theirs = run_episode(world, theirs_controller, seed=3, config=SHORT)
    same_episode(ours, theirs)
    assert theirs.summary()["method_source"].startswith(f"{HERE}:{external} in ")
    assert "method_source" not in ours.summary()


def test_writing_over_its_inputs_does_not_reach_the_episode():
    world = load_world("R1")
    clean = run_episode(world, make_controller(f"{HERE}:Straight"), config=SHORT)
    external_methods.SEEN.clear()
    dirty = run_episode(world, make_controller(f"{HERE}:MutatingPlanner"), config=SHORT)
    same_episode(clean, dirty)
    assert external_methods.SEEN and (external_methods.SEEN[0] == 1e6).all()  # it did write
    assert clean.steps > 10 and np.isnan(dirty.log["tau"]).all()  # no DWA parameters chosen
    zero = run_episode(world, make_controller(f"{HERE}:Zero"), config=SHORT)
    overwritten = run_episode(world, make_controller(f"{HERE}:MutatingChooser"), config=SHORT)
    same_episode(zero, overwritten)
    assert np.abs(overwritten.observations).max() < 1e5


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("NaNCommand", "command\\(\\) returned \\(nan, 0.0\\) at step 2: not finite"),
        ("TooFast", "returned \\(0.9, 0.0\\) at step 2: beyond the robot's limits"),
        ("ThreeNumbers", "not a pair"),
        ("TextCommand", "not two real numbers"),
        ("RaisesMidEpisode", "command\\(\\) raised at step 4: ZeroDivisionError: the method's"),
        ("OutOfSet", "choose\\(\\) returned 100 at step 0: not an index of its 100 actions"),
        ("FloatIndex", "choose\\(\\) returned 3.0 at step 0: not a whole number"),
    ],
)
def test_a_wrong_answer_ends_the_episode_in_one_line(name, said):
    with pytest.raises(ExternalMethodError, match=f"method '{HERE}:{name}': .*{said}") as err:
        run_episode(load_world("R1"), make_controller(f"{HERE}:{name}"), config=SHORT)
    assert "\n" not in str(err.value)


def test_a_call_over_the_control_period_is_recorded():
    result = run_episode(load_world("R1"), make_controller(f"{HERE}:Slow"), config=SHORT)
    assert result.overruns == 1 and result.summary()["overruns"] == 1
    fast = run_episode(load_world("R1"), make_controller(f"{HERE}:Straight"), config=SHORT)
    assert fast.overruns == 0
    same_episode(fast, result)  # the simulation did not wait for it
