"""The Gymnasium env: checker, spaces, seeding, reward and episode ends, training-world guard."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import d3dwa_bullet.learning.env  # noqa: F401  (registers the env id)
from d3dwa_bullet import ENV_ID
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.reward import reward
from d3dwa_bullet.learning.training import TrainConfig
from d3dwa_bullet.params import RewardParams
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.world.model import World

PROGRESS = ACTIONS_FULL.encode((3.0, 1.0, 2.0, 3.0))
"""A progress-heavy action that drives straight to a free goal."""


def _run(env: D3DWAEnv, actions, seed: int):
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, False, False, info)]
    for a in actions:
        step = env.step(a)
        out.append(step)
        if step[2] or step[3]:
            break
    return out


def test_check_env_passes(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,))
    check_env(env, skip_render_check=True)
    env.close()


def test_gymnasium_make_and_spaces(open_world: World) -> None:
    env = gym.make(ENV_ID, worlds=(open_world,))
    assert env.observation_space.shape == (12,)
    assert env.observation_space.dtype == np.float32
    np.testing.assert_array_equal(env.observation_space.low, [0, -1, -1, -1] + [0] * 8)
    np.testing.assert_array_equal(env.observation_space.high, [1.0] * 12)
    assert env.action_space == gym.spaces.Discrete(100)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert info["world"] == "open" and info["outcome"] is None
    obs, r, terminated, truncated, info = env.step(PROGRESS)
    assert set(info) >= {"outcome", "world", "tau", "weights", "fallback"}
    assert info["tau"] == 3.0 and info["weights"] == (3.0, 1.0, 2.0)
    env.close()


def test_weights_only_action_space(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,), weights_only=True)
    assert env.action_space == gym.spaces.Discrete(25)
    assert env.actions == ACTIONS_WEIGHTS_ONLY
    env.reset(seed=1)
    for a in (0, 7, 24):
        *_, info = env.step(a)
        assert info["tau"] == 4.0
        assert info["weights"] == tuple(ACTIONS_WEIGHTS_ONLY.decode(a)[:3])
    with pytest.raises(ConfigError):
        env.step(25)
    env.close()


def test_same_seed_same_episode_and_trajectory() -> None:
    """A generated layout and a sampled noise profile: both must follow the reset seed."""

    def make() -> D3DWAEnv:
        return D3DWAEnv(worlds=(), generators=("R1-style",), noise=("real",))

    actions = [int(a) for a in np.random.default_rng(3).integers(0, 100, size=25)]
    a, b = make(), make()
    ra, rb = _run(a, actions, 11), _run(b, actions, 11)
    assert ra[0][4]["world"] == rb[0][4]["world"] and ra[0][4]["world"].startswith("R1-style-s")
    assert len(ra) == len(rb)
    for sa, sb in zip(ra, rb, strict=True):
        np.testing.assert_array_equal(sa[0], sb[0])
        assert sa[1:4] == sb[1:4]
    first = a.episode_seed
    a.reset(seed=12)
    assert a.episode_seed != first
    a.close()
    b.close()


def test_tasks_sampled_by_weight(open_world: World, post_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world, post_world), generators=("R2-style",), generator_prob=0.5)
    assert env.tasks == ("open", "post", "R2-style")
    np.testing.assert_allclose(env.task_probabilities, [0.25, 0.25, 0.5])
    env.set_task_weights({"open": 0.0, "R2-style": 0.0})
    seen = {env.reset(seed=s)[1]["task"] for s in range(4)}
    assert seen == {"post"}
    with pytest.raises(ConfigError):
        env.set_task_weights([0.0, 0.0, 0.0])
    env.close()


def test_reward_terms_and_goal_terminates(open_world: World) -> None:
    params = RewardParams(scale=0.01)
    env = D3DWAEnv(worlds=(open_world,), reward_scale=0.01)
    _, info = env.reset(seed=0)
    prev = info
    for _ in range(200):
        obs, r, terminated, truncated, info = env.step(PROGRESS)
        expected = reward(
            info["outcome"],
            prev["goal_distance"],
            info["goal_distance"],
            prev["obstacle_distance"],
            info["obstacle_distance"],
            params,
        )
        assert r == pytest.approx(expected)
        prev = info
        if terminated or truncated:
            break
    assert info["outcome"] == "goal" and info["is_success"]
    assert terminated and not truncated
    assert r > 0.5 * 0.99  # +50 / 100, shaping on top
    with pytest.raises(RuntimeError):
        env.step(PROGRESS)
    env.close()


def test_time_limit_truncates(post_world: World) -> None:
    env = D3DWAEnv(worlds=(replace(post_world, time_limit=0.5),), reward_scale=1.0)
    env.reset(seed=0)
    for i in range(5):
        obs, r, terminated, truncated, info = env.step(PROGRESS)
        if i < 4:
            assert not (terminated or truncated)
    assert truncated and not terminated
    assert info["outcome"] == "timeout"
    assert r == pytest.approx(-2.02, abs=0.16)  # timeout + step, +- shaping
    env.close()


def test_collision_terminates(post_world: World, monkeypatch: pytest.MonkeyPatch) -> None:
    env = D3DWAEnv(worlds=(post_world,), reward_scale=1.0)
    env.reset(seed=0)
    observe = env.episode.observe

    def crash():
        obs = observe()
        env.episode.outcome = "collision"
        return obs

    monkeypatch.setattr(env.episode, "observe", crash)
    *_, r, terminated, truncated, info = env.step(PROGRESS)
    assert terminated and not truncated and info["outcome"] == "collision"
    assert r == pytest.approx(-2.02, abs=0.16)
    env.close()


def test_evaluation_worlds_refused_for_training() -> None:
    for name in ("US1", "H1", "H2", "H3", "R1", "R2", "R3"):
        with pytest.raises(ConfigError, match="evaluation-only"):
            D3DWAEnv(worlds=(name,))
    with pytest.raises(ConfigError, match="evaluation-only"):
        TrainConfig(worlds=("TS1", "US1"))
    with pytest.raises(ConfigError, match="evaluation-only"):
        TrainConfig(eval_worlds=("H3",))


def test_reset_option_world_guarded(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,))
    with pytest.raises(ConfigError, match="evaluation-only"):
        env.reset(seed=0, options={"world": "H1"})
    env.close()
    env = D3DWAEnv(worlds=(open_world,), allow_eval_worlds=True)
    _, info = env.reset(seed=0, options={"world": "R1"})
    assert info["world"] == "R1"
    env.close()


def test_reset_and_close_close_the_simulator(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,))
    env.reset(seed=0)
    first = env.episode
    env.reset(seed=1)
    assert first.sim.client is None and env.episode.sim.client is not None
    last = env.episode
    env.close()
    assert last.sim.client is None and env.episode is None


@pytest.mark.parametrize(
    "action",
    [2.5, 3.0, np.float32(3), np.float64(2.5), True, np.bool_(True), "a", None, [3], 100, -1],
)
def test_step_refuses_anything_but_an_integer_in_the_space(open_world: World, action) -> None:
    env = D3DWAEnv(worlds=(open_world,))
    env.reset(seed=0)
    with pytest.raises(ConfigError, match=r"D3DWAEnv\.step: action .* is not an integer in"):
        env.step(action)
    for ok in (PROGRESS, np.int64(PROGRESS), np.array(PROGRESS)):  # a vector env's action
        env.step(ok)
    env.close()


def test_reset_refuses_unknown_options_naming_the_known_ones(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,))
    with pytest.raises(ConfigError, match=r"unknown option\(s\) \['bogus'\]; known: world, noise"):
        env.reset(seed=0, options={"bogus": 1, "noise": "none"})
    env.reset(seed=0, options={"noise": "none", "episode_seed": 3})
    env.close()


def test_human_render_mode_without_a_display_is_refused(open_world: World, monkeypatch) -> None:
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(ConfigError, match="render_mode='human' .* no display .* DISPLAY"):
        D3DWAEnv(worlds=(open_world,), render_mode="human")


def test_progress_observation_space_and_unknown_kinds(open_world: World) -> None:
    env = D3DWAEnv(worlds=(open_world,), observation="progress")
    assert env.observation_space.shape == (17,)
    np.testing.assert_array_equal(env.observation_space.low, [0, -1, -1, -1] + [0] * 13)
    paper = D3DWAEnv(worlds=(open_world,))
    (obs, _), (obs12, _) = env.reset(seed=3), paper.reset(seed=3)
    assert env.observation_space.contains(obs) and obs[12:].tolist() == [0.0] * 5
    for _ in range(3):
        obs, *_ = env.step(PROGRESS)
        obs12, *_ = paper.step(PROGRESS)
    np.testing.assert_array_equal(obs[:12], obs12)  # the paper's entries, unchanged
    np.testing.assert_allclose(obs[13:], [1.0, 1 / 3, 2 / 3, 0.6], rtol=1e-6)
    env.close()
    paper.close()
    with pytest.raises(ConfigError, match="D3DWAEnv observation: unknown observation kind 'lidar'"):
        D3DWAEnv(worlds=(open_world,), observation="lidar")


def test_stall_penalty_reaches_the_env_reward(open_world: World) -> None:
    # the robot cannot leave a 0.5 m circle in 0.3 s: every step after stall_after pays
    priced = RewardParams(scale=0.01, stall_penalty=-1.0, stall_after=0.15)
    env, paper = (
        D3DWAEnv(worlds=(open_world,), reward_params=priced),
        D3DWAEnv(worlds=(open_world,)),
    )
    rewards = np.array([[s[1] for s in _run(e, [PROGRESS] * 3, 5)[1:]] for e in (env, paper)])
    np.testing.assert_allclose(rewards[0] - rewards[1], [0.0, -0.01, -0.01], atol=1e-12)
    env.close()
    paper.close()


def test_decision_steps_hold_an_action_and_sum_its_rewards(open_world: World) -> None:
    """Beyond the paper: one step of decision_steps=4 is four control steps of one action."""
    one = D3DWAEnv(worlds=(open_world,), decision_steps=1)
    four = D3DWAEnv(worlds=(open_world,), decision_steps=4)
    fine = _run(one, [PROGRESS] * 600, seed=5)
    coarse = _run(four, [PROGRESS] * 150, seed=5)
    assert fine[-1][4]["outcome"] == coarse[-1][4]["outcome"] == "goal"
    n_fine = len(fine) - 1
    assert len(coarse) - 1 == -(-n_fine // 4)  # ceil: the last decision stops at the goal
    assert sum(s[4]["control_steps"] for s in coarse[1:]) == n_fine
    for k in range(1, len(coarse)):  # each decision's reward is the sum of its four steps
        assert coarse[k][1] == pytest.approx(sum(s[1] for s in fine[4 * k - 3 : 4 * k + 1]))
        np.testing.assert_array_equal(coarse[k][0], fine[min(4 * k, n_fine)][0])
    for bad in (0, 101, 2.0, True):
        with pytest.raises(ConfigError, match="decision_steps"):
            D3DWAEnv(worlds=(open_world,), decision_steps=bad)
    one.close()
    four.close()
