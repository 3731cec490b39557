"""Noise models: identity by default, seeded, independent streams, statistics as configured."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.sim.noise import STREAMS, NoiseModel, encoder_wheel_speed, ground_wheel_speed
from d3dwa_bullet.sim.noise_config import (
    ImuConfig,
    LatencyConfig,
    LidarNoiseConfig,
    NoiseConfig,
    OdometryConfig,
    PhysicsConfig,
    PoseFixConfig,
    SlipConfig,
)

RANGE_MIN, RANGE_MAX = 0.05, 10.0
#: A scan with every kind of beam: valid, +inf, -inf, NaN, 0.0, out of range.
SCAN = np.array([0.5, 1.0, np.inf, -np.inf, np.nan, 0.0, 12.0, 0.01, 3.3, RANGE_MIN, RANGE_MAX])

ALL_ON = NoiseConfig(
    slip=SlipConfig(level_mean=0.05, level_std=0.02, step_std=0.01),
    lidar=LidarNoiseConfig(
        range_std=0.02,
        dropout_prob=0.1,
        dropout_kinds=(0.2, 0.5, 0.3),
        spurious_prob=0.05,
        spurious_min=0.1,
        spurious_max=1.0,
    ),
    odometry=OdometryConfig(
        radius_error_std=0.01, track_error_std=0.01, walk_std=0.01, yaw_walk_std=0.01
    ),
    imu=ImuConfig(gyro_std=0.01, bias_std=0.02, bias_walk_std=0.001),
    latency=LatencyConfig(steps=1),
    physics=PhysicsConfig(
        friction_scale_range=(0.5, 1.5), mass_scale_range=(0.8, 1.2), torque_scale_range=(0.7, 1.0)
    ),
    pose_fix=PoseFixConfig(rate_hz=2.0, pos_std=0.05, yaw_std=0.05, dropout_prob=0.2),
)

#: Each model alone: the config group it lives in and the streams it may draw from.
MODELS = {
    "slip": ("slip",),
    "lidar": ("lidar_range", "lidar_dropout", "lidar_spurious"),
    "imu": ("imu",),
    "latency": (),
    "physics": ("physics",),
    "pose_fix": ("pose_fix",),
}


def only(group: str) -> NoiseConfig:
    """ALL_ON with every group but ``group`` back at its default."""
    return NoiseConfig(**{group: getattr(ALL_ON, group)})


def trace(model: NoiseModel, steps: int = 30, group: str | None = None) -> list:
    """Run every method for a few control steps and collect what they return."""
    out: list = [model.physics, model.slip_level.tolist(), model.gyro_bias]
    ranges = np.tile(SCAN, 20)
    for k in range(steps):
        t = 0.1 * k
        if group in (None, "slip"):
            out.append(model.wheel_slip_ratio().tolist())
        if group in (None, "lidar"):
            out.append(model.corrupt_ranges(ranges, RANGE_MIN, RANGE_MAX).tobytes())
        if group in (None, "imu"):
            out.append(model.gyro(0.3 * math.sin(t), 0.1))
        if group in (None, "latency"):
            out.append(model.delay((0.1 * k, -0.05 * k)))
        if group in (None, "pose_fix"):
            out.append(model.pose_fix(t, (t, -t, 0.1 * t)))
    return out


def test_default_config_is_identity_and_draws_nothing() -> None:
    model = NoiseModel(NoiseConfig(), seed=123)
    fresh = NoiseModel(NoiseConfig(), seed=123)
    assert not NoiseConfig().enabled
    for k in range(5):
        assert np.array_equal(model.wheel_slip_ratio(), np.zeros(2))
        out = model.corrupt_ranges(SCAN, RANGE_MIN, RANGE_MAX)
        assert out is not SCAN and out.tobytes() == SCAN.tobytes()
        w = 0.123456789 * k
        assert model.gyro(w, 0.1) == w
        cmd = (0.3, -1.2)
        assert model.delay(cmd) == cmd
        assert model.pose_fix(0.1 * k, (1.0, 2.0, 3.0)) is None
    assert (model.friction_scale, model.mass_scale, model.torque_scale) == (1.0, 1.0, 1.0)
    assert model.gyro_bias == 0.0 and np.array_equal(model.slip_level, np.zeros(2))
    for name in STREAMS:
        assert model.rngs[name].bit_generator.state == fresh.rngs[name].bit_generator.state


def test_corrupt_ranges_does_not_modify_input() -> None:
    model = NoiseModel(ALL_ON, seed=1)
    before = SCAN.copy()
    model.corrupt_ranges(SCAN, RANGE_MIN, RANGE_MAX)
    assert SCAN.tobytes() == before.tobytes()


def test_same_seed_same_draws_bit_for_bit() -> None:
    assert trace(NoiseModel(ALL_ON, seed=42)) == trace(NoiseModel(ALL_ON, seed=42))


@pytest.mark.parametrize("seeds", [(0, 1), (42, 43), (7, 2**40)])
def test_different_seeds_differ(seeds: tuple[int, int]) -> None:
    a, b = (trace(NoiseModel(ALL_ON, seed=s), steps=5) for s in seeds)
    assert a != b


@pytest.mark.parametrize("group", [g for g in MODELS if g != "latency"])
def test_streams_independent_of_other_models(group: str) -> None:
    alone = trace(NoiseModel(only(group), seed=5), group=group)
    together = trace(NoiseModel(ALL_ON, seed=5), group=group)
    # Compare only this model's outputs (physics, slip level, bias are always recorded).
    if group != "physics":
        alone, together = alone[3:], together[3:]
    else:
        alone, together = alone[:1], together[:1]
    assert alone == together


@pytest.mark.parametrize("group", list(MODELS))
def test_model_only_draws_from_its_streams(group: str) -> None:
    model = NoiseModel(only(group), seed=9)
    fresh = NoiseModel(NoiseConfig(), seed=9)
    trace(model)
    for name in STREAMS:
        if name not in MODELS[group]:
            assert model.rngs[name].bit_generator.state == fresh.rngs[name].bit_generator.state, (
                name
            )


@pytest.mark.parametrize(
    "kinds", [(0.2, 0.5, 0.3), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.5, 0.0, 0.5)]
)
def test_dropout_kind_proportions(kinds: tuple[float, float, float]) -> None:
    n = 100_000
    model = NoiseModel(
        NoiseConfig(lidar=LidarNoiseConfig(dropout_prob=1.0, dropout_kinds=kinds)), seed=3
    )
    out = model.corrupt_ranges(np.full(n, 2.0), RANGE_MIN, RANGE_MAX)
    observed = np.array([np.isnan(out).mean(), np.isposinf(out).mean(), (out == 0.0).mean()])
    assert observed.sum() == pytest.approx(1.0)
    tol = 4 * np.sqrt(0.25 / n)  # 4 sigma of a proportion
    assert np.all(np.abs(observed - np.array(kinds)) < tol)
    for k, p in enumerate(kinds):
        if p == 0:
            assert observed[k] == 0


@pytest.mark.parametrize("prob", [0.0, 0.02, 0.3])
def test_dropout_rate(prob: float) -> None:
    n = 100_000
    cfg = NoiseConfig(lidar=LidarNoiseConfig(dropout_prob=prob, dropout_kinds=(0.3, 0.4, 0.3)))
    out = NoiseModel(cfg, seed=4).corrupt_ranges(np.full(n, 2.0), RANGE_MIN, RANGE_MAX)
    dropped = ~np.isfinite(out) | (out == 0.0)
    assert abs(dropped.mean() - prob) < 4 * np.sqrt(0.25 / n)
    if prob > 0:
        assert np.isnan(out).any() and np.isposinf(out).any() and (out == 0.0).any()


def test_range_noise_statistics_and_invalid_beams_untouched() -> None:
    std = 0.03
    model = NoiseModel(NoiseConfig(lidar=LidarNoiseConfig(range_std=std)), seed=11)
    ranges = np.full(50_000, 2.0)
    out = model.corrupt_ranges(ranges, RANGE_MIN, RANGE_MAX)
    assert abs((out - 2.0).std() - std) < 0.05 * std and abs((out - 2.0).mean()) < 0.002
    invalid = model.corrupt_ranges(SCAN, RANGE_MIN, RANGE_MAX)
    bad = ~(np.isfinite(SCAN) & (SCAN > 0) & (SCAN >= RANGE_MIN) & (SCAN <= RANGE_MAX))
    assert invalid[bad].tobytes() == SCAN[bad].tobytes()
    assert np.all((invalid[~bad] >= RANGE_MIN) & (invalid[~bad] <= RANGE_MAX))


def test_spurious_returns_in_configured_interval() -> None:
    cfg = LidarNoiseConfig(spurious_prob=0.1, spurious_min=0.2, spurious_max=0.4)
    out = NoiseModel(NoiseConfig(lidar=cfg), seed=2).corrupt_ranges(
        np.full(20_000, 5.0), RANGE_MIN, RANGE_MAX
    )
    phantom = out != 5.0
    assert abs(phantom.mean() - 0.1) < 0.01
    assert np.all((out[phantom] >= 0.2) & (out[phantom] <= 0.4))


def test_slip_bounds_and_episode_level() -> None:
    cfg = NoiseConfig(slip=SlipConfig(level_mean=0.3, level_std=0.3, step_std=0.3))
    for seed in range(50):
        model = NoiseModel(cfg, seed=seed)
        assert np.all((model.slip_level >= 0) & (model.slip_level <= 0.5))
        s = np.array([model.wheel_slip_ratio() for _ in range(20)])
        assert s.shape == (20, 2) and np.all((s >= 0) & (s <= 0.9))
    steady = NoiseModel(NoiseConfig(slip=SlipConfig(level_mean=0.02)), seed=0)
    assert np.array_equal(steady.slip_level, [0.02, 0.02])
    assert np.array_equal(steady.wheel_slip_ratio(), [0.02, 0.02])


def test_slip_semantics_round_trip() -> None:
    omega_cmd, slip = np.array([10.0, -4.0]), np.array([0.1, 0.3])
    joint = ground_wheel_speed(omega_cmd, slip)
    assert np.allclose(joint, [9.0, -2.8])
    assert np.allclose(encoder_wheel_speed(joint, slip), omega_cmd)


def test_gyro_white_noise_and_bias() -> None:
    cfg = NoiseConfig(imu=ImuConfig(gyro_std=0.01, bias_std=0.05))
    readings = []
    for seed in range(400):
        model = NoiseModel(cfg, seed=seed)
        readings.append([model.gyro(1.0, 0.1) - 1.0 for _ in range(50)])
    r = np.array(readings)
    per_episode_bias = r.mean(axis=1)
    assert abs(per_episode_bias.std() - 0.05) < 0.01
    assert abs((r - per_episode_bias[:, None]).std() - 0.01) < 0.001


def test_gyro_bias_walk_grows_like_sqrt_time() -> None:
    cfg = NoiseConfig(imu=ImuConfig(bias_walk_std=0.01))
    finals = []
    for seed in range(400):
        model = NoiseModel(cfg, seed=seed)
        for _ in range(100):
            model.gyro(0.0, 0.1)
        finals.append(model.gyro_bias)
    assert abs(np.std(finals) - 0.01 * math.sqrt(10.0)) < 0.01


@pytest.mark.parametrize("steps", [1, 2, 5])
def test_latency_fifo(steps: int) -> None:
    model = NoiseModel(NoiseConfig(latency=LatencyConfig(steps=steps)), seed=0)
    issued = [(0.1 * k, 0.01 * k) for k in range(1, 12)]
    applied = [model.delay(c) for c in issued]
    assert applied[:steps] == [(0.0, 0.0)] * steps
    assert applied[steps:] == issued[: len(issued) - steps]


def test_pose_fix_rate_noise_and_dropout() -> None:
    cfg = NoiseConfig(pose_fix=PoseFixConfig(rate_hz=2.0, pos_std=0.05, yaw_std=0.02))
    model = NoiseModel(cfg, seed=0)
    t, fixes = 0.0, []
    for _ in range(100):  # 10 s at 10 Hz, time by repeated addition like a control loop
        fix = model.pose_fix(t, (1.0, 2.0, math.pi - 0.001))
        if fix is not None:
            fixes.append((t, fix))
        t += 0.1
    assert len(fixes) == 20
    assert [round(ti, 6) for ti, _ in fixes[:3]] == [0.0, 0.5, 1.0]
    f = np.array([fx for _, fx in fixes])
    assert np.all(np.abs(f[:, :2] - [1.0, 2.0]) < 0.25)
    assert np.all((f[:, 2] >= -math.pi) & (f[:, 2] < math.pi))  # wrapped
    dropped = NoiseConfig(pose_fix=PoseFixConfig(rate_hz=10.0, dropout_prob=0.5))
    model = NoiseModel(dropped, seed=0)
    got = [model.pose_fix(0.1 * k, (0.0, 0.0, 0.0)) for k in range(4000)]
    assert abs(np.mean([g is None for g in got]) - 0.5) < 0.04
    assert all(g == (0.0, 0.0, 0.0) for g in got if g is not None)


def test_physics_scales_within_ranges() -> None:
    for seed in range(30):
        model = NoiseModel(only("physics"), seed=seed)
        assert 0.5 <= model.friction_scale <= 1.5
        assert 0.8 <= model.mass_scale <= 1.2
        assert 0.7 <= model.torque_scale <= 1.0
    fixed = NoiseModel(NoiseConfig(physics=PhysicsConfig(mass_scale_range=(1.3, 1.3))), seed=0)
    assert (fixed.friction_scale, fixed.mass_scale, fixed.torque_scale) == (1.0, 1.3, 1.0)


@pytest.mark.parametrize(
    ("factory", "needle"),
    [
        (lambda: SlipConfig(level_std=-0.1), "slip.level_std"),
        (lambda: SlipConfig(level_mean=0.7), "slip.level_mean"),
        (lambda: LidarNoiseConfig(range_std=-0.01), "lidar.range_std"),
        (lambda: LidarNoiseConfig(range_std=math.nan), "lidar.range_std"),
        (lambda: LidarNoiseConfig(dropout_prob=1.5), "lidar.dropout_prob"),
        (lambda: LidarNoiseConfig(spurious_prob=-0.1), "lidar.spurious_prob"),
        (lambda: LidarNoiseConfig(dropout_kinds=(0.5, 0.5, 0.5)), "lidar.dropout_kinds"),
        (lambda: LidarNoiseConfig(dropout_kinds=(1.2, -0.2, 0.0)), "lidar.dropout_kinds"),
        (lambda: LidarNoiseConfig(dropout_kinds=(0.5, 0.5)), "lidar.dropout_kinds"),
        (lambda: LidarNoiseConfig(spurious_min=0.6, spurious_max=0.5), "lidar.spurious_min"),
        (lambda: OdometryConfig(walk_std=-1.0), "odometry.walk_std"),
        (lambda: ImuConfig(bias_std=-0.01), "imu.bias_std"),
        (lambda: LatencyConfig(steps=-1), "latency.steps"),
        (lambda: LatencyConfig(steps=1.5), "latency.steps"),
        (lambda: PhysicsConfig(mass_scale_range=(1.2, 0.8)), "physics.mass_scale_range"),
        (lambda: PhysicsConfig(friction_scale_range=(0.0, 1.0)), "physics.friction_scale_range"),
        (lambda: PoseFixConfig(rate_hz=-1.0), "pose_fix.rate_hz"),
        (lambda: PoseFixConfig(dropout_prob=2.0), "pose_fix.dropout_prob"),
        (lambda: NoiseConfig.from_dict({"lidr": {}}), "lidr"),
        (lambda: NoiseConfig.from_dict({"lidar": {"range_sd": 0.1}}), "range_sd"),
        (lambda: NoiseModel(NoiseConfig(), seed=None), "seed"),
    ],
)
def test_validation_names_parameter(factory, needle: str) -> None:
    with pytest.raises(ConfigError, match=needle.replace(".", r"\.")):
        factory()


@pytest.mark.parametrize("config", [NoiseConfig(), ALL_ON, only("lidar"), only("physics")])
def test_to_dict_round_trip(config: NoiseConfig) -> None:
    data = config.to_dict()
    assert NoiseConfig.from_dict(data) == config
    assert NoiseConfig.from_dict(data).enabled == config.enabled


@pytest.mark.parametrize(
    "group", ["slip", "lidar", "odometry", "imu", "latency", "physics", "pose_fix"]
)
def test_enabled_per_group(group: str) -> None:
    assert only(group).enabled
    assert getattr(only(group), group).enabled
