"""The PyBullet shell: a driven Kachaka in a static world, its lidar, noise and estimator.

Physics runs at ``SimParams.physics_hz`` (240 Hz), control at ``control_hz`` (10 Hz). A
commanded twist is clipped to the velocity limits and rate-limited by the acceleration
limits, turned into wheel speeds, and sent to the two wheel joints as velocity motors with
a torque limit; Bullet's contacts and friction do the rest. Every PyBullet call passes
``physicsClientId``, so several simulators may share a process.

Each control step (``step``), in order, with noise on:

1. the command enters the latency FIFO (``NoiseModel.delay``),
2. slip: the joints turn at ``(1 - s)`` of the wheel speed, the encoders see all of it,
3. physics sub-steps,
4. wheel odometry from the encoders, the gyro, and the EKF (odometry, gyro, predict, and a
   pose fix when one is due).

Encoders count wheel turns and a 10 Hz consumer of a fast IMU reads its rate averaged over
the period, so both report the *mean* rate over the control period just ended (joint-angle
and true-yaw differences), not the rate at its end: the latter over-counts every
acceleration and made exact odometry drift by centimetres per metre. Those mean rates
describe the motion from the previous step to now, so the EKF fuses them *before* it
predicts to now; predicting first would integrate the previous period's rates and lag the
pose by one period (4 cm at 0.4 m/s, 0.2 rad at 2 rad/s).

With the default (all-off) noise the estimate *is* ground truth, so noise-free runs are
exactly the simulator's own.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from d3dwa_bullet.geometry import wrap_angle_modular
from d3dwa_bullet.params import RobotLimits, SimParams
from d3dwa_bullet.resources import urdf_path
from d3dwa_bullet.robot import AXLE_HEIGHT, LIDAR_MOUNT, TRACK, WHEEL_RADIUS
from d3dwa_bullet.sim.backend import BackendBase
from d3dwa_bullet.sim.bullet import p
from d3dwa_bullet.sim.estimator import PoseEstimator
from d3dwa_bullet.sim.lidar import Lidar, LidarParams
from d3dwa_bullet.sim.noise import NoiseModel, encoder_wheel_speed, ground_wheel_speed
from d3dwa_bullet.sim.odometry import WheelOdometry
from d3dwa_bullet.timing import StageClock, perf
from d3dwa_bullet.world.model import Box, Cylinder, World, obstacle_outline

CAPLESS_HEIGHT = AXLE_HEIGHT + LIDAR_MOUNT[2] + 0.05
"""Obstacles taller than this (m above the floor: the lidar's height plus 5 cm) collide by their
walls alone; their top and bottom caps are only drawn (:meth:`Simulator._add_obstacles`)."""


#: Worlds whose mesh lists :func:`obstacle_mesh` keeps per process: more than BARN's 300, since a
#: training run on BARN draws one of its 250 train worlds every episode (a list evicted is never
#: freed, PyBullet holding its items, so a smaller cache would leak one world's lists an episode
#: again). A generated layout is new every episode, cached or not.
MESH_CACHE_SIZE = 512


@functools.lru_cache(maxsize=MESH_CACHE_SIZE)
def obstacle_mesh(
    obstacles: tuple[Box | Cylinder, ...],
) -> tuple[list[list[float]], list[int], list[int]]:
    """(vertices (V, 3) m, collision triangles, drawn triangles) of the obstacles as one mesh:
    each outline's prism, walls and (as fans over the convex outline) caps; a tall obstacle's
    caps are drawn only (``CAPLESS_HEIGHT``).

    Cached, and the same list objects handed to PyBullet every episode on a world: PyBullet
    keeps a reference to every item of the vertex and index sequences it is given and never
    lets go, so lists built anew each episode grew an evaluation worker by 5-15 MB an episode
    on BARN (docs/benchmarks.md#memory); the same objects cost that once per world and process."""
    vertices: list[list[float]] = []
    sides: list[int] = []
    caps: list[int] = []
    for ob in obstacles:
        outline = obstacle_outline(ob)
        n, base = len(outline), len(vertices)
        vertices += [[x, y, 0.0] for x, y in outline] + [[x, y, ob.height] for x, y in outline]
        for i in range(n):
            j = (i + 1) % n
            sides += [base + i, base + j, base + n + j, base + i, base + n + j, base + n + i]
        fans = []  # caps: fans over a convex outline
        for i in range(1, n - 1):
            fans += [base + n, base + n + i, base + n + i + 1, base, base + i + 1, base + i]
        (caps if ob.height > CAPLESS_HEIGHT else sides).extend(fans)
    return vertices, sides, sides + caps


@dataclass(frozen=True)
class DriveParams:
    """Actuation: wheel motors and contact friction."""

    wheel_torque: float = 1.5
    """Torque limit per wheel motor, N m (6.8 kg at 2 m/s^2 needs ~0.31 N m per wheel)."""
    wheel_friction: float = 1.0
    """Lateral friction coefficient of the wheels (and the floor)."""
    solver_iterations: int = 20
    """Bullet constraint-solver iterations per sub-step."""
    cone_friction: bool = False
    """Bullet's exact friction cone instead of its two-direction pyramid. The pyramid is the
    usual choice for wheels on a flat floor and costs 20 % less physics time per step
    (measured 1.7 vs 2.1 ms per control step); speeds and paths agree to a few mm over 10 s."""


class Simulator(BackendBase):
    """One Kachaka in one world, headless unless gui=True."""

    def __init__(
        self,
        world: World,
        sim: SimParams = SimParams(),
        limits: RobotLimits = RobotLimits(),
        lidar: LidarParams = LidarParams(),
        drive: DriveParams = DriveParams(),
        noise: NoiseModel | None = None,
        gui: bool = False,
    ):
        self.world, self.sim, self.limits, self.drive = world, sim, limits, drive
        self.noise = noise if noise is not None else NoiseModel()
        self.noisy = self.noise.config.enabled
        self.clock = StageClock()
        """Seconds per stage of the control steps so far (physics, lidar, noise, estimator)."""
        self.client = p.connect(p.GUI if gui else p.DIRECT)
        cid = self.client
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        # One stepSimulation call per control period runs `substeps` internal steps of
        # 1 / physics_hz each: the same integration as calling it substeps times, without
        # the Python round trips.
        p.setPhysicsEngineParameter(
            fixedTimeStep=sim.control_period,
            numSubSteps=sim.substeps,
            numSolverIterations=drive.solver_iterations,
            enableConeFriction=int(drive.cone_friction),
            physicsClientId=cid,
        )
        friction = drive.wheel_friction * self.noise.friction_scale
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        self.ground = p.createMultiBody(0, plane, physicsClientId=cid)
        p.changeDynamics(self.ground, -1, lateralFriction=friction, physicsClientId=cid)
        self.obstacles = self._add_obstacles(world.obstacles)
        x, y, yaw = world.start
        self.robot = p.loadURDF(
            str(urdf_path()),
            [x, y, AXLE_HEIGHT],
            p.getQuaternionFromEuler([0, 0, yaw]),
            physicsClientId=cid,
        )
        joints = {
            p.getJointInfo(self.robot, j, physicsClientId=cid)[1].decode(): j
            for j in range(p.getNumJoints(self.robot, physicsClientId=cid))
        }
        self.wheels = [joints["left_wheel_joint"], joints["right_wheel_joint"]]
        for j in self.wheels:
            p.changeDynamics(self.robot, j, lateralFriction=friction, physicsClientId=cid)
        for name in ("front_caster_joint", "rear_caster_joint"):
            # Casters are free-rolling balls: no traction, no drag.
            p.changeDynamics(
                self.robot, joints[name], lateralFriction=0.0, rollingFriction=0.0,
                spinningFriction=0.0, physicsClientId=cid,
            )  # fmt: skip
        if self.noise.mass_scale != 1.0:
            mass = p.getDynamicsInfo(self.robot, -1, physicsClientId=cid)[0]
            p.changeDynamics(self.robot, -1, mass=mass * self.noise.mass_scale, physicsClientId=cid)
        self.torque = drive.wheel_torque * self.noise.torque_scale
        self._com_offset = p.getDynamicsInfo(self.robot, -1, physicsClientId=cid)[3][:2]
        links = {
            p.getJointInfo(self.robot, j, physicsClientId=cid)[12].decode(): j
            for j in range(p.getNumJoints(self.robot, physicsClientId=cid))
        }
        self.lidar = Lidar(cid, self.robot, links["lidar_link"], lidar)
        self.odometry = WheelOdometry(
            WHEEL_RADIUS, TRACK, self.noise.config.odometry, self.noise.odometry_rng
        )
        self.odometry.reset(world.start)
        self.estimator = PoseEstimator(pose=world.start, t=0.0)
        self._last_angles = self._wheel_angles()  # encoder reference, rad
        self._last_yaw = self.true_pose()[2]  # gyro reference, rad
        self.step_count = 0
        self.command = (0.0, 0.0)  # last rate-limited command actually sent, (v, w)
        self.velocity_estimate = (0.0, 0.0)
        self._apply_wheels(0.0, 0.0, np.zeros(2))
        if self.noisy:
            self._fuse(0.0, (0.0, 0.0), 0.0)

    # -- world -------------------------------------------------------------------------
    def _add_obstacles(self, obstacles: tuple[Box | Cylinder, ...]) -> list[int]:
        """All static obstacles as one concave triangle mesh (one body, or none).

        Bullet casts rays against triangles far faster than against convex boxes (measured:
        0.9 vs 3.5 ms for 481 beams in TS1), and contacts with a static mesh are exact.
        Cylinders become prisms of ``world.model.CYLINDER_SEGMENTS`` sides (radial error < 0.3 mm).
        """
        if not obstacles:
            return []
        vertices, sides, drawn = obstacle_mesh(obstacles)
        cid = self.client
        # A tall obstacle collides by its walls only: the lidar's rays are horizontal, below its
        # top, and the robot can reach a cap only through a wall, so no ray or contact ever met
        # those caps; dropping them halves the mesh and the lidar's cost in clutter
        # (docs/benchmarks.md#barn-cost), every episode the same. A low obstacle keeps its caps.
        shape = p.createCollisionShape(
            p.GEOM_MESH, vertices=vertices, indices=sides, flags=p.GEOM_FORCE_CONCAVE_TRIMESH,
            physicsClientId=cid,
        )  # fmt: skip
        visual = p.createVisualShape(
            p.GEOM_MESH, vertices=vertices, indices=drawn, rgbaColor=[0.55, 0.55, 0.6, 1],
            physicsClientId=cid,
        )  # fmt: skip
        return [p.createMultiBody(0, shape, visual, [0, 0, 0], physicsClientId=cid)]

    # -- state -------------------------------------------------------------------------
    def true_pose(self) -> tuple[float, float, float]:
        """Ground-truth base_link pose (x, y, yaw), m and rad.

        PyBullet reports the base's centre of mass (the URDF inertial origin, 4.35 cm ahead of
        base_link); the inertial offset is rotated and subtracted to get base_link itself.
        """
        pos, orn = p.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)
        yaw = p.getEulerFromQuaternion(orn)[2]
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy = self._com_offset
        return float(pos[0] - (c * ox - s * oy)), float(pos[1] - (s * ox + c * oy)), float(yaw)

    def true_velocity(self) -> tuple[float, float]:
        """Ground-truth body-frame (v, w): forward speed m/s, yaw rate rad/s."""
        lin, ang = p.getBaseVelocity(self.robot, physicsClientId=self.client)
        yaw = self.true_pose()[2]
        return float(math.cos(yaw) * lin[0] + math.sin(yaw) * lin[1]), float(ang[2])

    def in_contact(self) -> bool:
        """True if the robot touches any obstacle (Bullet contact points)."""
        cid = self.client
        return any(p.getContactPoints(self.robot, ob, physicsClientId=cid) for ob in self.obstacles)

    def true_ranges(self) -> np.ndarray:
        """The lidar's true ranges at the present pose (``rayTestBatch``): (beams,) float64, m."""
        return self.lidar.ranges()

    # -- control -----------------------------------------------------------------------
    def _apply_wheels(self, v: float, w: float, slip: np.ndarray) -> None:
        omega = np.array(
            [(v - 0.5 * TRACK * w) / WHEEL_RADIUS, (v + 0.5 * TRACK * w) / WHEEL_RADIUS]
        )
        target = ground_wheel_speed(omega, slip) if self.noisy else omega
        p.setJointMotorControlArray(
            self.robot, self.wheels, p.VELOCITY_CONTROL, targetVelocities=target.tolist(),
            forces=[self.torque, self.torque], physicsClientId=self.client,
        )  # fmt: skip

    def step(self, v: float, w: float) -> tuple[float, float]:
        """Run one control period under command (v, w). Returns the command applied."""
        clock, t = self.clock, perf()
        slip = self._take_command(v, w)
        t = clock.charge("noise", t)
        self._apply_wheels(*self.command, slip)
        p.stepSimulation(physicsClientId=self.client)
        self.step_count += 1
        t = clock.charge("physics", t)
        if self.noisy:
            dt = self.sim.control_period
            angles = self._wheel_angles()
            enc = encoder_wheel_speed((angles - self._last_angles) / dt, slip)
            yaw = self.true_pose()[2]
            w_mean = wrap_angle_modular(yaw - self._last_yaw) / dt
            self._last_angles, self._last_yaw = angles, yaw
            _, _, _, ov, ow = self.odometry.update(float(enc[0]), float(enc[1]), dt)
            self._fuse(self.time, (ov, ow), w_mean)
            clock.charge("estimator", t)
        return self.command

    def _wheel_angles(self) -> np.ndarray:
        """Joint angles of the (left, right) drive wheels: (2,) float64, rad."""
        states = p.getJointStates(self.robot, self.wheels, physicsClientId=self.client)
        return np.array([s[0] for s in states], dtype=np.float64)

    def close(self) -> None:
        if self.client is not None and p.isConnected(physicsClientId=self.client):
            p.disconnect(physicsClientId=self.client)
        self.client = None  # type: ignore[assignment]
