"""The kinematic backend against PyBullet: ray cast, motion, contact; and its refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.params import RobotLimits
from d3dwa_bullet.robot import BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH
from d3dwa_bullet.sim.backend import check_backend, limit_command, make_simulator
from d3dwa_bullet.sim.kinematic import KinematicSimulator, torque_accel
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.noise_config import NoiseConfig, SlipConfig
from d3dwa_bullet.sim.planar import body_touches, pack_obstacles
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.model import Box, Cylinder, World

SMALL = World(
    "small", "boxes, cylinders and a low box around the start", (0.0, 0.0, 0.3), (4.0, 0.0),
    obstacles=(
        Box((2.0, 0.5), (0.4, 1.2), yaw=0.4),
        Box((-1.5, -1.0), (0.3, 0.3), yaw=-1.1),
        Cylinder((1.0, -1.2), 0.3),
        Cylinder((0.2, 1.5), 0.075),
        Cylinder((-0.8, 0.9), 0.5),
        Box((1.0, 1.0), (0.5, 0.5), height=0.1),  # under the lidar's beams (0.15 m)
    ),
)  # fmt: skip


def test_ray_cast_matches_ray_test_batch_on_a_small_world():
    poses = [(0.0, 0.0, 0.3), (0.5, -0.4, 2.5), (-0.3, 0.4, -1.9), (1.2, 0.2, math.pi)]
    for pose in poses:
        world = World("small", "", pose, (4.0, 0.0), obstacles=SMALL.obstacles)
        with Simulator(world) as bullet:
            ref = bullet.lidar.ranges()
        mine = KinematicSimulator(world).true_ranges()
        # a cylinder is Bullet's 48-gon, inside the true circle by up to r (1 - cos(pi / 48)):
        # ranges agree to a millimetre but for grazing beams, which may hit one and miss the other
        assert (np.isfinite(ref) != np.isfinite(mine)).sum() <= 1, pose
        hit = np.isfinite(ref) & np.isfinite(mine)
        assert hit.sum() > 100
        diff = np.abs(ref[hit] - mine[hit])
        assert np.median(diff) < 1.1e-3 and np.quantile(diff, 0.95) < 3e-3 and diff.max() < 0.01, (
            pose
        )


def test_ray_cast_never_sees_an_obstacle_under_the_beams():
    low = World(
        "low", "", (0.0, 0.0, 0.0), (4.0, 0.0), obstacles=(Box((1.0, 0.0), (0.4, 2.0), height=0.1),)
    )
    assert not np.isfinite(KinematicSimulator(low).true_ranges()).any()
    tall = World("tall", "", (0.0, 0.0, 0.0), (4.0, 0.0), obstacles=(Box((1.0, 0.0), (0.4, 2.0)),))
    ahead = KinematicSimulator(tall).true_ranges()[
        240
    ]  # the forward beam from the lidar at x=0.156
    assert ahead == pytest.approx(0.8 - 0.156, abs=1e-9)


def test_a_field_of_view_of_a_full_turn_wraps():
    from d3dwa_bullet.sim.lidar_params import LidarParams

    world = World(
        "behind", "", (0.0, 0.0, 0.0), (4.0, 0.0), obstacles=(Cylinder((-2.0, 0.0), 0.3),)
    )
    sim = KinematicSimulator(world, lidar=LidarParams(fov=2 * math.pi, increment=math.radians(1.0)))
    ranges = sim.true_ranges()
    # beams 0 and 360 both point straight back, at the cylinder 2.156 m behind the lidar
    assert ranges[0] == pytest.approx(2.156 - 0.3, abs=1e-6)
    assert ranges[-1] == pytest.approx(2.156 - 0.3, abs=1e-6)


def test_motion_follows_pybullet_within_centimetres():
    world = World("empty", "", (0.0, 0.0, 0.0), (9.0, 0.0))
    rng = np.random.default_rng(3)
    commands = [
        (rng.uniform(0.0, 0.4), rng.uniform(-2.0, 2.0)) for _ in range(10) for _ in range(4)
    ]
    with Simulator(world) as bullet:
        ref = [(bullet.step(*c), bullet.true_pose())[1] for c in commands]
    sim = KinematicSimulator(world)
    mine = [(sim.step(*c), sim.true_pose())[1] for c in commands]
    err = np.hypot(*(np.array(ref)[:, :2] - np.array(mine)[:, :2]).T)
    assert err.max() < 0.03  # 4 s and about a metre of mixed turns


def test_both_backends_rate_limit_the_command_alike():
    world = World("empty", "", (0.0, 0.0, 0.0), (9.0, 0.0))
    sim = KinematicSimulator(world)
    applied = limit_command(RobotLimits(), 0.1, (0.0, 0.0), 0.4, 2.0)
    assert sim.step(0.4, 2.0) == applied == pytest.approx((0.2, 0.3))


def test_wheels_follow_their_target_at_the_motors_acceleration():
    world = World("empty", "", (0.0, 0.0, 0.0), (9.0, 0.0))
    sim = KinematicSimulator(world)
    sim.step(0.4, 0.0)  # rate-limited to 0.2 m/s, reached within the period
    v, w = sim.true_velocity()
    assert v == pytest.approx(0.2 * 0.046 / 0.045, rel=1e-9) and w == pytest.approx(0.0, abs=1e-12)
    heavy = NoiseModel(NoiseConfig(), 0)
    assert torque_accel(0.5, 2.0) < torque_accel() / 3  # half the torque on twice the mass
    assert heavy.torque_scale == 1.0


def test_contact_is_the_body_box_against_an_obstacle():
    rows = pack_obstacles(World("c", "", (0, 0, 0), (1, 0), obstacles=(Cylinder((1.0, 0.0), 0.2),)))
    front = BODY_CENTER_X + BODY_HALF_LENGTH  # 0.237 m ahead of base_link
    args = (BODY_CENTER_X, BODY_HALF_LENGTH, BODY_HALF_WIDTH, 0.0)
    assert body_touches(rows, 1.0 - 0.2 - front + 0.001, 0.0, 0.0, *args)
    assert not body_touches(rows, 1.0 - 0.2 - front - 0.001, 0.0, 0.0, *args)
    # side on: the cylinder 0.2 + 0.12 m to the left of the body centre
    assert body_touches(rows, 1.0 - BODY_CENTER_X, -0.319, 0.0, *args)
    assert not body_touches(rows, 1.0 - BODY_CENTER_X, -0.321, 0.0, *args)
    boxes = pack_obstacles(
        World("b", "", (0, 0, 0), (1, 0), obstacles=(Box((1.0, 0.0), (0.2, 0.2), yaw=0.785),))
    )
    corner = 0.1 * math.sqrt(2.0)  # a diamond: its corner points at the robot
    assert body_touches(boxes, 1.0 - corner - front + 0.001, 0.0, 0.0, *args)
    assert not body_touches(boxes, 1.0 - corner - front - 0.001, 0.0, 0.0, *args)


def test_contact_comes_within_a_step_of_pybullets_when_driving_into_a_wall():
    world = World("wall", "", (0.0, 0.0, 0.0), (9.0, 0.0), obstacles=(Box((1.5, 0.0), (0.2, 3.0)),))

    def first_contact(sim) -> int:
        for k in range(60):
            sim.step(0.3, 0.0)
            if sim.in_contact():
                return k
        return -1

    with Simulator(world) as bullet:
        ref = first_contact(bullet)
    mine = first_contact(KinematicSimulator(world))
    assert ref > 0 and abs(mine - ref) <= 1, (ref, mine)


def test_the_same_seed_gives_the_same_noisy_episode():
    noise = NoiseConfig(slip=SlipConfig(level_mean=0.05, level_std=0.02, step_std=0.02))

    def drive(seed: int) -> tuple:
        sim = KinematicSimulator(SMALL, noise=NoiseModel(noise, seed))
        for _ in range(20):
            sim.step(0.3, 0.5)
        return sim.true_pose(), sim.estimate()

    assert drive(4) == drive(4)
    assert drive(4) != drive(5)


def test_make_simulator_and_its_refusals():
    assert isinstance(make_simulator("kinematic", SMALL), KinematicSimulator)
    with pytest.raises(ConfigError, match=r"--backend 'bullet': not one of pybullet, kinematic"):
        check_backend("bullet")
    with pytest.raises(ConfigError, match="--gui draws PyBullet's world; --backend kinematic"):
        make_simulator("kinematic", SMALL, gui=True)

    class Mesh:
        height = 1.0

    odd = World("odd", "", (0.0, 0.0, 0.0), (1.0, 0.0), obstacles=(Mesh(),))  # type: ignore[arg-type]
    with pytest.raises(
        ConfigError, match="world 'odd': obstacle 0 is a Mesh; the kinematic backend"
    ):
        KinematicSimulator(odd)


def test_a_world_the_backend_cannot_cast_is_refused_before_any_episode(tmp_path):
    from d3dwa_bullet.episode import EpisodeConfig
    from d3dwa_bullet.evaluation.jobs import Job, evaluate
    from d3dwa_bullet.sim.backend import check_backend_worlds

    class Mesh:
        height = 1.0

    odd = World(
        "odd", "", (0.0, 0.0, 0.0), (1.0, 0.0), obstacles=(Cylinder((3.0, 0.0), 0.2), Mesh())
    )  # type: ignore[arg-type]
    check_backend_worlds("pybullet", [odd])  # PyBullet's own loaders decide there
    with pytest.raises(
        ConfigError, match="world 'odd': obstacle 1 is a Mesh; --backend kinematic casts boxes"
    ):
        check_backend_worlds("kinematic", [SMALL, odd])
    with pytest.raises(ConfigError, match="obstacle 1 is a Mesh"):
        evaluate(
            [Job(odd, "dwa3", 0)],
            tmp_path / "out",
            config=EpisodeConfig(backend="kinematic"),
            progress=False,
        )
    assert not (tmp_path / "out" / "results.csv").exists()
