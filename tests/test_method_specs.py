"""The method registry's reference methods: `random` uniform over the 100 actions and
`random-weights` over the 25 weights-only ones, drawn from their own stream of the episode
seed, methods without a policy (docs/design/methods.md#methods)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import run_episode
from d3dwa_bullet.errors import ConfigError, UnknownNameError
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.evaluation.policy_runs import PolicyRun, method_runs, policy_digests
from d3dwa_bullet.method_specs import (
    FIXED,
    HELD_REFERENCE,
    LABELS,
    LEARNED,
    METHODS,
    REFERENCE,
    SHIPPED_DECISION_STEPS,
    check_method,
    floors_of,
    method_family,
    method_label,
    needs_policy,
    reference_of,
)
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.resources import configs_dir

OBS = np.zeros(12)


def draws(seed: int, n: int) -> list[int]:
    """The first n action indices of a random controller reset with seed."""
    controller = make_controller("random")
    controller.reset(seed)
    return [controller(OBS)[0] for _ in range(n)]


def test_random_is_a_reference_method_without_a_policy():
    assert "random" in METHODS and not needs_policy("random") and "random" not in FIXED
    assert method_family("random") == "reference" and method_family("dwa1") == "fixed"
    assert method_family("d3dwa") == "learned"
    assert LABELS["random"] == "Random (uniform over 100 actions)"
    controller = make_controller("random")
    assert controller.actions == ACTIONS_FULL and controller.source == "reference"
    assert method_runs(["dwa1", "random"]) == [PolicyRun("dwa1"), PolicyRun("random")]
    assert policy_digests(method_runs(["random"])) == {}


def test_random_weights_draws_uniformly_over_the_25_weights_only_actions():
    assert method_family("random-weights") == "reference" and not needs_policy("random-weights")
    assert LABELS["random-weights"] == "Random (uniform over 25 actions)"
    controller = make_controller("random-weights")
    assert controller.actions == ACTIONS_WEIGHTS_ONLY and controller.source == "reference"
    controller.reset(7)
    picked = [controller(OBS) for _ in range(2500)]
    assert all(action == ACTIONS_WEIGHTS_ONLY.decode(i) for i, action in picked)
    assert {action.tau for _, action in picked} == {4.0}  # the weights-only set's one horizon
    counts = np.bincount([i for i, _ in picked], minlength=25)
    assert counts.size == 25 and counts.min() > 60  # 100 expected a cell


def test_every_learned_action_set_has_a_reference_drawing_from_it():
    """SPEC 6: the floor is uniform over the method's own action set."""
    for method, actions in LEARNED.items():
        assert any(ref == actions for ref in REFERENCE.values()), method


@pytest.mark.parametrize("method", ["random", "dwa1"])
def test_a_policy_for_a_method_that_needs_none_is_refused(method, tmp_path):
    with pytest.raises(ConfigError) as err:
        make_controller(method, tmp_path / "p")
    line = str(err.value)
    assert "\n" not in line and f"--policy {tmp_path / 'p'}" in line and "needs no policy" in line
    with pytest.raises(ConfigError) as err:
        make_controller(method, onnx=tmp_path / "p.onnx")
    assert f"{tmp_path / 'p.onnx'}: method {method!r} does not run a network" in str(err.value)


def test_same_seed_same_draws_and_the_action_matches_its_index():
    assert draws(7, 200) == draws(7, 200)
    controller = make_controller("random")
    controller.reset(7)
    for _ in range(20):
        index, action = controller(OBS)
        assert action == ACTIONS_FULL.decode(index)
    controller.reset(7)  # a reset starts the episode's stream again
    assert [controller(OBS)[0] for _ in range(200)] == draws(7, 200)


def test_different_seeds_give_different_draws():
    sequences = {tuple(draws(seed, 50)) for seed in range(20)}
    assert len(sequences) == 20


def test_draws_cover_the_action_set_uniformly():
    counts = np.bincount(draws(0, 5000), minlength=ACTIONS_FULL.size)
    assert counts.size == 100 and counts.min() > 0
    # Pearson's chi-square against 50 a cell: 99 degrees of freedom, mean 99, sd 14; a loose
    # bound (about 6 sd) that a biased draw (e.g. one horizon block twice as likely) exceeds
    chi2 = float(((counts - 50.0) ** 2 / 50.0).sum())
    assert chi2 < 185.0, chi2
    per_horizon = counts.reshape(4, 25).sum(axis=1)  # horizon-major: 1250 each expected
    assert np.all(np.abs(per_horizon - 1250) < 150), per_horizon


def test_the_draws_ignore_the_observation():
    controller = make_controller("random")
    controller.reset(3)
    observed = [controller(np.full(12, float(k)))[0] for k in range(100)]
    assert observed == draws(3, 100)


def test_without_a_reset_it_refuses_to_draw():
    with pytest.raises(RuntimeError, match="reset"):
        make_controller("random")(OBS)


def test_a_negative_episode_seed_is_refused_naming_it():
    with pytest.raises(ConfigError, match=r"--seed -1: method 'random'"):
        make_controller("random").reset(-1)


def test_other_controllers_ignore_reset():
    controller = make_controller("dwa2")
    controller.reset(5)
    assert controller(OBS) == (-1, FIXED["dwa2"])


def test_same_episode_seed_gives_the_same_episode_bit_for_bit(post_world):
    world = post_world.with_task(time_limit=3.0)
    a = run_episode(world, make_controller("random"), seed=3)
    b = run_episode(world, make_controller("random"), seed=3)
    assert a.summary() == b.summary() and a.steps == 30
    for k in a.log:
        assert np.array_equal(a.log[k], b.log[k]), k
    assert a.log["action"].astype(int).tolist() == draws(3, 30)
    table = ACTIONS_FULL.table()[a.log["action"].astype(int)]
    np.testing.assert_array_equal(
        np.column_stack([a.log[k] for k in ("wp", "wc", "ws", "tau")]), table
    )
    assert len(set(a.log["tau"].tolist())) > 1  # it picks horizons, as the tau figures show
    c = run_episode(world, make_controller("random"), seed=4)
    assert c.log["action"].tolist() != a.log["action"].tolist()


def test_one_controller_reused_over_episodes_restarts_its_stream(post_world):
    world = post_world.with_task(time_limit=1.0)
    controller = make_controller("random")
    first = run_episode(world, controller, seed=2)
    run_episode(world, controller, seed=9)
    again = run_episode(world, controller, seed=2)
    assert first.log["action"].tolist() == again.log["action"].tolist()


def test_its_draws_are_a_stream_of_their_own(post_world):
    """Noise draws from the same episode seed, and changes what the robot sees: the actions
    are the same with and without it."""
    world = post_world.with_task(time_limit=1.0)
    quiet = run_episode(world, make_controller("random"), seed=5)
    noisy = run_episode(
        world, make_controller("random"), seed=5, noise=make_noise("real", 5), noise_name="real"
    )
    assert not np.array_equal(noisy.observations, quiet.observations)
    assert noisy.log["action"].tolist() == quiet.log["action"].tolist()


def test_a_controller_built_by_hand_is_not_uniform():
    controller = Controller("mine", actions=ACTIONS_FULL, policy=lambda obs: 42)
    controller.reset(0)
    assert controller(OBS) == (42, ACTIONS_FULL.decode(42))


def test_a_held_controller_chooses_every_k_steps_and_a_reset_ends_the_hold():
    """A policy trained with decision_steps k (beyond the paper) is asked every k steps."""
    calls = []

    def policy(obs):
        calls.append(float(obs[0]))
        return len(calls) % ACTIONS_FULL.size

    held = Controller("d3dwa", policy=policy, actions=ACTIONS_FULL, hold=3)
    held.reset(0)
    indices = [held(np.full(12, float(t)))[0] for t in range(7)]
    assert indices == [1, 1, 1, 2, 2, 2, 3]
    assert calls == [0.0, 3.0, 6.0]  # asked at steps 0, 3, 6 only
    held.reset(1)  # a new episode asks at once
    assert held(np.full(12, 9.0))[0] == 4 and calls[-1] == 9.0
    plain = Controller("d3dwa", policy=policy, actions=ACTIONS_FULL)
    assert [plain(np.zeros(12))[0] for _ in range(2)] == [5, 6]


def test_each_reference_method_plots_in_its_own_grey_and_the_others_keep_their_colours():
    from d3dwa_bullet.evaluation.plotting import method_colours

    colours = method_colours(["dwa1", "random", "random-weights", "d3dwa"])
    greys = [colours["random"], colours["random-weights"]]
    assert all(c[0] == c[1] == c[2] for c in greys) and greys[0] != greys[1]
    assert colours["d3dwa"] == method_colours(["d3dwa"])["d3dwa"]
    assert len(set(colours["dwa1"][:3])) > 1  # a contender is not grey


def test_the_default_tables_hold_the_reference_for_the_shipped_decision_period():
    assert HELD_REFERENCE == ("random@10", "random-weights@10")
    for config in configs_dir().glob("*.yaml"):  # the held floor is the shipped policies' period
        assert yaml.safe_load(config.read_text())["decision_steps"] == SHIPPED_DECISION_STEPS
    assert reference_of("random@10") == ("random", 10) and reference_of("random") == ("random", 1)
    assert reference_of("d3dwa") is None and method_family("random-weights@3") == "reference"
    assert method_label("random@10") == "Random (uniform over 100 actions, held 10 steps)"
    assert method_label("random-weights@7") == "Random (uniform over 25 actions, held 7 steps)"
    assert floors_of("d3dwa") == ("random", "random@10")
    assert floors_of("dqdwa") == ("random-weights", "random-weights@10")
    controller = make_controller("random-weights@10")
    assert controller.hold == 10 and controller.actions == ACTIONS_WEIGHTS_ONLY


def test_held_10_changes_the_action_only_every_10_steps_and_draws_the_same_stream():
    controller = make_controller("random@10")
    controller.reset(5)
    held = [controller(OBS)[0] for _ in range(60)]
    assert all(held[k] == held[k - k % 10] for k in range(60))
    assert held[::10] == draws(5, 6)  # one draw per decision, from the same stream
    assert len(set(held[::10])) > 1


def test_the_held_reference_with_hold_1_is_the_every_step_references_episode(post_world):
    world = post_world.with_task(time_limit=3.0)
    for base in REFERENCE:
        every = run_episode(world, make_controller(base), seed=4)
        held_1 = run_episode(world, make_controller(f"{base}@1"), seed=4)
        assert every.summary() | {"method": ""} == held_1.summary() | {"method": ""}
        for k in every.log:
            assert np.array_equal(every.log[k], held_1.log[k]), k
    held = run_episode(world, make_controller("random@10"), seed=4).log["action"].astype(int)
    assert held.tolist() == [a for a in draws(4, 3) for _ in range(10)]


@pytest.mark.parametrize(
    ("name", "says"),
    [
        ("random@0", "decision period '0' is not a whole number of control steps >= 1"),
        ("random@-1", "decision period '-1' is not a whole number"),
        ("random-weights@1.5", "decision period '1.5' is not a whole number"),
        ("random@", "decision period '' is not a whole number"),
        ("random@101", "decision period: 101 control steps is over the limit of 100"),
        ("random@99999999999", "decision period: 99999999999 control steps is over the limit"),
    ],
)
def test_a_bad_decision_period_is_refused_naming_it(name, says, capsys):
    with pytest.raises(ConfigError) as err:
        check_method(name)
    assert says in str(err.value) and name[:12] in str(err.value)
    assert main(["eval", "--methods", name, "--worlds", "R1", "--out", "/nonexistent/x"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and says in lines[0]
    with pytest.raises(UnknownNameError):
        check_method("dwa1@10")  # only a reference method takes a decision period
