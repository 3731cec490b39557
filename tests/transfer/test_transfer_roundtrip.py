"""Record a simulated episode as a bag, replay it through the same pipeline: the same
observations (to 1e-9; in fact bit for bit) and the same actions at every step.

This is the test that the simulator and the bag replay are really one pipeline. Episodes
are cut to a few seconds here; ``test_full_episodes_round_trip`` (slow) runs them whole.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader

from d3dwa_bullet.controllers import make_controller
from d3dwa_bullet.episode import EpisodeConfig, EpisodeResult, run_episode
from d3dwa_bullet.episode_metrics import body_clearance, posture_displacement, trajectory_length
from d3dwa_bullet.evaluation.jobs import make_noise
from d3dwa_bullet.learning.agents import D3QNAgent, D3QNConfig, save_checkpoint
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.resources import profiles_dir
from d3dwa_bullet.world.registry import load_world
from transfer.bag_reader import read_bag
from transfer.bag_writer import BagRecorder
from transfer.replay import replay_bag
from transfer.replay_output import ReplayResult
from transfer.sim_bridge import (
    DEFAULT_START_NS,
    make_step_fn,
    mean_body_rates,
    record_episode,
)
from transfer.topics import ROLE_TYPES, TopicMap

OBS_TOLERANCE = 1e-9
SHORT = 3.0  # s of sim time per round-trip episode in the fast tests
PERIOD_NS = 100_000_000
CONFIG = EpisodeConfig()
#: (world, noise) -> (outcome, steps) of the whole seed-0 episodes of the test policy.
FULL_EPISODES = {
    ("R1", "none"): ("timeout", 600),
    ("R1", "real"): ("goal", 90),
    ("R2", "none"): ("timeout", 600),
    ("R2", "real"): ("timeout", 600),
    ("R3", "none"): ("goal", 209),
    ("R3", "real"): ("goal", 334),
}


@pytest.fixture(scope="module")
def policy_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An untrained D3QN over all 100 actions: its choices vary with the observation (seed 3
    picks several actions within a few seconds), which is what the round trip must match."""
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=(32, 32), seed=3))
    return save_checkpoint(tmp_path_factory.mktemp("policy") / "d3dwa", agent, method="d3dwa")


def record(
    bag: Path,
    world: str,
    method: str,
    policy: Path | None,
    noise: str,
    seed: int = 0,
    time_limit: float | None = SHORT,
    **recorder_options,
) -> EpisodeResult:
    results: list[EpisodeResult] = []
    with BagRecorder(bag, **recorder_options) as rec:
        record_episode(
            world, method, policy, noise, seed, rec, time_limit=time_limit, on_result=results.append
        )
    return results[0]


def round_trip_report(episode: EpisodeResult, replay: ReplayResult) -> dict:
    """Compare a replay with the episode it was recorded from; returns the figures."""
    log, rows = episode.log, replay.rows
    assert replay.replayed == episode.steps == len(rows) and replay.skipped == {}
    obs = np.array([r.observation for r in rows])
    diff = float(np.abs(obs - episode.observations).max())
    actions = np.array([r.action for r in rows])
    commands = np.array([r.cmd for r in rows])
    return {
        "steps": episode.steps,
        "max_obs_diff": diff,
        "action_agreement": float(np.mean(actions == log["action"])),
        "command_agreement": float(
            np.mean((commands == np.column_stack((log["v_cmd"], log["w_cmd"]))).all(axis=1))
        ),
        "distinct_actions": len(set(actions.tolist())),
    }


def summary_from_bag(
    bag_path: Path, replay: ReplayResult, episode: EpisodeResult, time_limit: float | None = None
) -> dict:
    """The episode's summary as its noise-free bag and replay tell it.

    Without noise the wheel odometry is ground truth, one pose per control period from the
    start to the end pose, so the metrics, and the outcome (the goal tolerance met at the
    end, else the time limit reached, else a collision), come from the bag alone.
    time_limit: s, the one the episode was recorded with (default: the world's).
    """
    world = load_world(episode.world)
    limit = time_limit or world.time_limit or CONFIG.termination.time_limit
    wheel = read_bag(bag_path).wheel_odometry
    poses = np.column_stack((wheel.x, wheel.y, wheel.yaw))
    steps = replay.replayed
    end_distance = math.dist(world.goal, poses[-1, :2])
    if end_distance <= CONFIG.termination.goal_tolerance:
        outcome = "goal"
    elif steps >= round(limit * CONFIG.sim.control_hz):
        outcome = "timeout"
    else:
        outcome = "collision"
    clearance = body_clearance(world, poses) if world.obstacles else np.array([np.inf])
    return {
        "world": world.name,
        "method": episode.method,
        "seed": episode.seed,
        "noise": "none",
        "outcome": outcome,
        "time_s": round(steps * CONFIG.sim.control_period, 3),
        "tl_m": round(trajectory_length(poses[:, :2]), 4),
        "pd_rad": round(posture_displacement(poses[:, 2]), 4),
        "min_clearance_m": round(float(clearance.min()), 4),
        "steps": steps,
    }


def assert_round_trip(episode: EpisodeResult, replay: ReplayResult) -> dict:
    report = round_trip_report(episode, replay)
    assert report["max_obs_diff"] <= OBS_TOLERANCE, report
    assert report["action_agreement"] == 1.0, report
    log, rows = episode.log, replay.rows
    np.testing.assert_array_equal(
        [r.cmd for r in rows], np.column_stack((log["v_cmd"], log["w_cmd"]))
    )
    np.testing.assert_array_equal(
        [r.weights for r in rows], np.column_stack((log["wp"], log["wc"], log["ws"]))
    )
    np.testing.assert_array_equal([r.tau for r in rows], log["tau"])
    np.testing.assert_array_equal(
        [r.pose for r in rows], np.column_stack((log["est_x"], log["est_y"], log["est_yaw"]))
    )
    # The bag's own record of the decisions agrees with the replay's.
    np.testing.assert_array_equal([r.recorded_cmd for r in rows], [r.cmd for r in rows])
    np.testing.assert_array_equal(
        [r.recorded_params for r in rows],
        [(*r.weights, r.tau, r.action) for r in rows],
    )
    return report


@pytest.fixture(scope="module")
def recordings(policy_dir, tmp_path_factory):
    """(world, noise) -> (bag, EpisodeResult): short learned-policy episodes, recorded once."""
    cache: dict[tuple[str, str], tuple[Path, EpisodeResult]] = {}

    def get(world: str, noise: str) -> tuple[Path, EpisodeResult]:
        if (world, noise) not in cache:
            bag = tmp_path_factory.mktemp("bags") / f"{world}_{noise}"
            cache[world, noise] = bag, record(bag, world, "d3dwa", policy_dir, noise, seed=2)
        return cache[world, noise]

    return get


@pytest.mark.parametrize("noise", ["none", "real"])
@pytest.mark.parametrize("world", ["R1", "R2", "R3"])
def test_round_trip_is_exact(world, noise, recordings, policy_dir):
    bag, episode = recordings(world, noise)
    replay = replay_bag(bag, step_fn=make_step_fn("d3dwa", policy_dir))
    report = assert_round_trip(episode, replay)
    assert report["steps"] == int(SHORT * 10)
    assert episode.outcome == "timeout"
    if noise == "none":
        assert summary_from_bag(bag, replay, episode, SHORT) == episode.summary()


@pytest.mark.parametrize("noise", ["none", "real"])
@pytest.mark.parametrize("world", ["R1", "R2", "R3"])
def test_the_learned_policy_really_varies_its_choice(world, noise, recordings):
    """Otherwise the round trip above would not exercise the learned path: in every recorded
    episode the policy picks several actions with at least two horizons, and each step's
    weights and horizon are those of the action it chose."""
    log = recordings(world, noise)[1].log
    actions = log["action"].astype(int)
    assert actions.min() >= 0 and len(set(actions.tolist())) >= 2
    assert len(set(log["tau"].tolist())) >= 2, sorted(set(log["tau"].tolist()))
    np.testing.assert_array_equal(
        ACTIONS_FULL.table()[actions], np.column_stack([log[f] for f in ("wp", "wc", "ws", "tau")])
    )


def test_ekf_mode_drifts_without_the_robots_localisation(recordings, policy_dir):
    """Re-fused without the localisation fixes (absent from the bag) the estimate drifts by
    centimetres over a few seconds; that mode is not meant to be exact."""
    bag, episode = recordings("R2", "real")
    replay = replay_bag(bag, step_fn=make_step_fn("d3dwa", policy_dir, estimator="ekf"))
    est = np.column_stack((episode.log["est_x"], episode.log["est_y"]))
    drift = np.abs(np.array([r.pose[:2] for r in replay.rows]) - est).max()
    assert 0.0 < drift < 0.1


def test_round_trip_of_a_fixed_method_in_a_ros1_bag(tmp_path):
    episode = record(
        tmp_path / "ep.bag", "R2", "dwa1", None, "harsh", seed=5, time_limit=2.0, storage="ros1"
    )
    replay = replay_bag(tmp_path / "ep.bag", step_fn=make_step_fn("dwa1"))
    assert_round_trip(episode, replay)
    assert set(replay.column("action")) == {-1.0}


def test_recording_leaves_the_episode_unchanged(tmp_path):
    """The recorder only watches: same seed, same episode, with or without a bag."""
    world = load_world("R3").with_task(time_limit=2.0)
    plain = run_episode(
        world, make_controller("dwa2"), seed=4, noise=make_noise("real", 4), noise_name="real"
    )
    recorded = record(tmp_path / "bag", world, "dwa2", None, "real", seed=4, time_limit=None)
    assert recorded.summary() == plain.summary()
    np.testing.assert_array_equal(recorded.observations, plain.observations)
    for name, values in plain.log.items():
        np.testing.assert_array_equal(recorded.log[name], values, err_msg=name)


def test_an_all_off_profile_records_like_no_noise(tmp_path):
    episode = record(
        tmp_path / "bag", "R1", "dwa3", None, str(profiles_dir() / "none.yaml"), time_limit=1.0
    )
    replay = replay_bag(tmp_path / "bag", step_fn=make_step_fn("dwa3"))
    assert_round_trip(episode, replay)


def test_recorded_bag_has_the_kachaka_topics_and_the_episode(recordings):
    path, episode = recordings("R1", "real")
    bag = read_bag(path)
    topics = TopicMap()
    assert bag.topics.topics == {role: getattr(topics, role) for role in topics.roles()}
    assert bag.notes == ["clock: header stamps"] and bag.corrupt == {}
    with AnyReader([path]) as reader:
        types = {name: info.msgtype for name, info in reader.topics.items()}
        counts = {name: info.msgcount for name, info in reader.topics.items()}
    assert types == {getattr(topics, role): ROLE_TYPES[role] for role in topics.roles()}
    steps = episode.steps
    assert counts[topics.scan] == counts[topics.odometry] == counts[topics.tf] == steps
    assert counts[topics.cmd_vel] == counts[topics.planner_params] == steps
    assert counts[topics.goal] == counts[topics.tf_static] == 1
    # One wheel-odometry and gyro sample per control period, from t = 0 to the last step's end.
    assert counts[topics.wheel_odometry] == counts[topics.imu] == steps + 1

    t = DEFAULT_START_NS + PERIOD_NS * np.arange(steps)
    np.testing.assert_array_equal(bag.scan_times_ns, t)
    np.testing.assert_array_equal(bag.odometry.t_ns, t)
    np.testing.assert_array_equal(
        bag.wheel_odometry.t_ns, DEFAULT_START_NS + PERIOD_NS * np.arange(steps + 1)
    )
    log = episode.log
    np.testing.assert_array_equal(bag.odometry.x, log["est_x"])
    np.testing.assert_array_equal(bag.odometry.yaw, log["est_yaw"])
    np.testing.assert_array_equal(bag.cmd_vel.values, np.column_stack((log["v_cmd"], log["w_cmd"])))
    np.testing.assert_array_equal(bag.planner_params.values[:, 4], log["action"])
    (goal,) = bag.goals
    assert (goal.x, goal.y, goal.frame_id) == (3.0, 0.0, "odom")
    assert (bag.mount.x, bag.mount.y, bag.mount.yaw) == (0.156, 0.0, 0.0)
    assert bag.mount_source == "static transform base_link -> lidar_link"
    start = load_world("R1").start
    assert (bag.wheel_odometry.x[0], bag.wheel_odometry.y[0], bag.wheel_odometry.yaw[0]) == start
    assert bag.wheel_odometry.v[0] == bag.wheel_odometry.w[0] == 0.0


def test_ekf_mode_is_the_simulators_filter(tmp_path):
    """Without localisation fixes the simulator's EKF fuses exactly the wheel odometry and
    gyro the bag holds, so re-fusing them replays its estimate (up to float rounding of t)."""
    profile = yaml.safe_load((profiles_dir() / "real.yaml").read_text())
    profile["name"] = "real-no-fixes"
    profile["params"]["pose_fix"]["rate_hz"] = 0.0
    (tmp_path / "nofix.yaml").write_text(yaml.safe_dump(profile))
    episode = record(
        tmp_path / "bag", "R3", "dwa3", None, str(tmp_path / "nofix.yaml"), seed=1, time_limit=2.0
    )
    replay = replay_bag(tmp_path / "bag", step_fn=make_step_fn("dwa3", estimator="ekf"))
    log = episode.log
    est = np.column_stack((log["est_x"], log["est_y"], log["est_yaw"]))
    np.testing.assert_allclose([r.pose for r in replay.rows], est, rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        [r.observation for r in replay.rows], episode.observations, rtol=0, atol=1e-9
    )


def test_mean_body_rates_inverts_the_arc():
    from d3dwa_bullet.geometry import arc_step

    for v, w in [(0.3, 0.0), (0.25, 1.5), (0.0, -2.0), (0.4, -0.7)]:
        end = arc_step(1.0, -2.0, 3.0, v, w, 0.1)
        got = mean_body_rates((1.0, -2.0, 3.0), end, 0.1)
        np.testing.assert_allclose(got, (v, w), atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["none", "real"])
@pytest.mark.parametrize("world", ["R1", "R2", "R3"])
def test_full_episodes_round_trip(world, noise, policy_dir, tmp_path):
    """Whole episodes (goal or the 60 s limit) with the learned path: the replay follows the
    episode to its end, and a noise-free bag tells the episode's own summary."""
    episode = record(tmp_path / "bag", world, "d3dwa", policy_dir, noise, seed=0, time_limit=None)
    replay = replay_bag(
        tmp_path / "bag", step_fn=make_step_fn("d3dwa", policy_dir), out_dir=tmp_path / "out"
    )
    assert_round_trip(episode, replay)
    assert (episode.outcome, episode.steps) == FULL_EPISODES[world, noise]
    assert replay.rows[-1].t == pytest.approx(episode.time_s - CONFIG.sim.control_period)
    if noise == "none":
        assert summary_from_bag(tmp_path / "bag", replay, episode) == episode.summary()
