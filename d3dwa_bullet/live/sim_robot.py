"""A simulated Kachaka behind the Kachaka API (``d3dwa serve``): the PyBullet simulator served
over the official gRPC service, the subset the live loop uses (docs/design/live.md#live).

What it serves, once per control period (a *snapshot*, all stamped alike):

* ``GetRosLaserScan``: the scan an episode's observation is built from (noise applied, float32
  as the simulator makes it), in the lidar frame (``lidar_link``) with the simulated lidar's
  layout (240 deg centred forward, 0.5 deg, REP-117 values);
* ``GetRosOdometry``: the robot's estimate, what ``d3dwa run`` observes (EKF with noise on,
  ground truth without), in ``odom``; here the odometry frame *is* the world's frame;
* ``GetRosWheelOdometry`` and ``GetRosImu``: raw wheel odometry and gyro as ``d3dwa record``
  writes them (the readings the simulator's EKF fused; exact mean rates without noise);
* ``GetRobotPose`` (the estimate, map = odometry frame here), ``GetPngMap`` (the world's
  occupancy at 5 cm), ``GetRobotVersion`` (this kachaka-api's), ``GetRobotSerialNumber``.

Stamps are ``start_ns`` + simulated time (a zero stamp would mean "unset"). Get requests
follow the API's cursor semantics: a request without a cursor (what ``KachakaApiClient``
sends) gets the newest snapshot at once; one carrying the newest snapshot's cursor waits for
the next one (up to its deadline).

Commands: ``SetRobotVelocity`` is refused (``success`` false) while manual control is off,
as the client expects (``set_robot_velocity`` then enables it and sends again). In
``lockstep`` mode each accepted command runs one control period and takes the next snapshot,
so a run is deterministic whatever the wall clock does; in ``realtime`` mode a thread steps
physics at the control rate with the newest command, and a command older than
``COMMAND_TIMEOUT_S`` counts as a stop (a silent client cannot drive the robot on). A
command that is not finite (NaN, inf) is an ``INVALID_ARGUMENT`` error and changes nothing:
every client shares this robot, so no client's input may break it for the others.
"""

from __future__ import annotations

import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any, Literal

import cv2
import grpc
import numpy as np
from kachaka_api.generated import kachaka_api_pb2 as pb2
from kachaka_api.generated.kachaka_api_pb2_grpc import (
    KachakaApiServicer,
    add_KachakaApiServicer_to_server,
)

from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.live.link import DEFAULT_PORT, api_version
from d3dwa_bullet.live.messages import (
    command_of,
    imu_message,
    odometry_message,
    scan_message,
)
from d3dwa_bullet.sim.noise import NoiseModel
from d3dwa_bullet.sim.simulator import Simulator
from d3dwa_bullet.world.grid import rasterize
from d3dwa_bullet.world.model import World
from transfer.sim_bridge import DEFAULT_START_NS, GyroTap, mean_body_rates

Mode = Literal["lockstep", "realtime"]
MODES: tuple[str, ...] = ("lockstep", "realtime")
COMMAND_TIMEOUT_S = 0.3
"""Realtime mode: a command older than this is replaced by a stop, s."""
MAP_RESOLUTION = 0.05
"""Cell size of the served map, m."""
_MAX_POLL_S = 1.0  # longest a cursor request waits for a new snapshot
_WORKERS = 16
"""Threads answering calls (start_server)."""
_MAX_WAITERS = _WORKERS // 2
"""Calls that may wait for the next snapshot at once: the other workers stay free for plain
reads and commands, whatever number of clients wait."""


class SimulatedKachaka(KachakaApiServicer):
    """The servicer: one simulated Kachaka in one world.

    noise: the episode's NoiseModel (None: none); mode: ``lockstep`` or ``realtime``.
    version: what GetRobotVersion answers (default: the installed kachaka-api's);
    serve_scan=False answers empty scans (a robot whose lidar is not up), serve_imu=False
    leaves GetRosImu unimplemented.
    """

    def __init__(
        self,
        world: World,
        *,
        noise: NoiseModel | None = None,
        config: EpisodeConfig = EpisodeConfig(),
        mode: Mode = "lockstep",
        version: str | None = None,
        start_ns: int = DEFAULT_START_NS,
        serve_scan: bool = True,
        serve_imu: bool = True,
    ) -> None:
        if mode not in MODES:
            raise ConfigError(f"unknown serve mode {mode!r}: choose one of {', '.join(MODES)}")
        self.world, self.config, self.mode = world, config, mode
        self.version = version if version is not None else api_version()
        self.start_ns = int(start_ns)
        self.serve_scan, self.serve_imu = serve_scan, serve_imu
        # tapped before the simulator exists, so readings[k] is the gyro of control period k
        self.tap = GyroTap(noise) if noise is not None else None
        self.sim = Simulator(
            world, sim=config.sim, limits=config.planner.limits, lidar=config.lidar, noise=noise
        )
        self._cond = threading.Condition()
        self._waiters = threading.BoundedSemaphore(_MAX_WAITERS)
        self._published: tuple[dict[str, Any], int] = ({}, 0)  # messages, cursor: one object
        self.cursor = 0
        """Snapshots taken so far (the cursor of the newest)."""
        self.truth: list[tuple[float, float, float]] = []
        """Ground-truth base_link pose at each snapshot."""
        self.received: list[tuple[float, float]] = []
        """Every velocity command accepted, (v, w) as decoded."""
        self.requests: list[tuple[float, float, bool]] = []
        """Every SetRobotVelocity call: (v, w, accepted); a refused one too."""
        self.manual_control = False
        self._latest: tuple[float, float, float] = (0.0, 0.0, -math.inf)  # v, w, monotonic s
        self._snapshot()
        self._map = self._png_map()
        self._running = threading.Event()
        self._thread: threading.Thread | None = None
        if mode == "realtime":
            self._running.set()
            self._thread = threading.Thread(target=self._realtime, name="sim-kachaka", daemon=True)
            self._thread.start()

    # -- the simulated robot -------------------------------------------------------------
    def _snapshot(self) -> None:
        """Sense once (as ``Episode.observe`` does: the noise streams advance alike) and
        publish every message of this control period."""
        sim = self.sim
        scan, _ = sim.sense()
        stamp = self.start_ns + scan.stamp_ns
        pose, velocity = sim.estimate()
        true = sim.true_pose()
        if sim.noisy:
            wheel_pose, wheel_twist = sim.odometry_pose(), (sim.odometry.v, sim.odometry.w)
        elif self.truth:
            wheel_pose = true
            wheel_twist = mean_body_rates(self.truth[-1], true, self.config.sim.control_period)
        else:
            wheel_pose, wheel_twist = true, (0.0, 0.0)
        gyro = self.tap.readings[-1] if self.tap is not None and sim.noisy else wheel_twist[1]
        messages = {
            "scan": scan_message(replace(scan, stamp_ns=stamp)),
            "odometry": odometry_message(pose, velocity, stamp),
            "wheel": odometry_message(wheel_pose, wheel_twist, stamp),
            "imu": imu_message(gyro, stamp),
            "pose": pb2.Pose(x=pose[0], y=pose[1], theta=pose[2]),
        }
        with self._cond:
            self.truth.append(true)
            self.cursor += 1
            self._published = (messages, self.cursor)  # what reads answer, swapped whole
            self._cond.notify_all()

    def _step(self, v: float, w: float) -> None:
        self.sim.step(v, w)
        self._snapshot()

    def _realtime(self) -> None:
        period = self.config.sim.control_period
        deadline = time.monotonic()
        while self._running.is_set():
            deadline += period
            v, w, sent = self._latest
            if time.monotonic() - sent > COMMAND_TIMEOUT_S:
                v = w = 0.0
            with self._cond:  # a close() waits for the step in progress
                if not self._running.is_set():
                    return
                self._step(v, w)
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:  # fell behind (a loaded machine): keep the rate from now on
                deadline = time.monotonic()

    def _png_map(self) -> pb2.Map:
        grid = rasterize(self.world, resolution=MAP_RESOLUTION)
        image = np.where(np.flipud(np.asarray(grid.values)), 0, 255).astype(np.uint8)
        ok, png = cv2.imencode(".png", image)
        half = 0.5 * MAP_RESOLUTION
        return pb2.Map(
            data=png.tobytes() if ok else b"",
            name=self.world.name,
            resolution=MAP_RESOLUTION,
            width=image.shape[1],
            height=image.shape[0],
            origin=pb2.Pose(x=grid.origin[0] - half, y=grid.origin[1] - half, theta=0.0),
        )

    def close(self) -> None:
        """Stop the realtime thread and disconnect the simulator."""
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        with self._cond:
            self.sim.close()

    # -- the service -----------------------------------------------------------------------
    def _newest(self, request: Any, context: grpc.ServicerContext) -> tuple[dict, Any]:
        """The newest snapshot; a request carrying its cursor waits for the next one. A plain
        read takes no lock (it never waits behind a physics step or a waiter), and a waiter
        past ``_MAX_WAITERS`` is answered at once, as a wait that saw no new snapshot."""
        messages, newest = self._published
        cursor = request.metadata.cursor
        if cursor and cursor == newest and self._waiters.acquire(blocking=False):
            try:
                remaining = context.time_remaining()
                wait = _MAX_POLL_S if remaining is None else min(_MAX_POLL_S, remaining)
                with self._cond:
                    self._cond.wait_for(
                        lambda: self._published[1] != cursor, timeout=max(wait, 0.0)
                    )
            finally:
                self._waiters.release()
            messages, newest = self._published
        return messages, pb2.Metadata(cursor=newest)

    def GetRobotVersion(self, request, context):  # noqa: N802 - the service's method names
        return pb2.GetRobotVersionResponse(version=self.version)

    def GetRobotSerialNumber(self, request, context):  # noqa: N802
        return pb2.GetRobotSerialNumberResponse(serial_number=f"d3dwa-sim-{self.world.name}")

    def GetRosLaserScan(self, request, context):  # noqa: N802
        messages, meta = self._newest(request, context)
        scan = messages["scan"] if self.serve_scan else pb2.RosLaserScan()
        return pb2.GetRosLaserScanResponse(metadata=meta, scan=scan)

    def GetRosOdometry(self, request, context):  # noqa: N802
        messages, meta = self._newest(request, context)
        return pb2.GetRosOdometryResponse(metadata=meta, odometry=messages["odometry"])

    def GetRosWheelOdometry(self, request, context):  # noqa: N802
        messages, meta = self._newest(request, context)
        return pb2.GetRosWheelOdometryResponse(metadata=meta, odometry=messages["wheel"])

    def GetRosImu(self, request, context):  # noqa: N802
        if not self.serve_imu:
            return super().GetRosImu(request, context)
        messages, meta = self._newest(request, context)
        return pb2.GetRosImuResponse(metadata=meta, imu=messages["imu"])

    def GetRobotPose(self, request, context):  # noqa: N802
        messages, meta = self._newest(request, context)
        return pb2.GetRobotPoseResponse(metadata=meta, pose=messages["pose"])

    def GetPngMap(self, request, context):  # noqa: N802
        return pb2.GetPngMapResponse(metadata=pb2.Metadata(cursor=1), map=self._map)

    def SetManualControlEnabled(self, request, context):  # noqa: N802
        self.manual_control = bool(request.enable)
        return pb2.SetManualControlEnabledResponse(result=pb2.Result(success=True))

    def GetManualControlEnabled(self, request, context):  # noqa: N802
        return pb2.GetManualControlEnabledResponse(enabled=self.manual_control)

    def SetRobotVelocity(self, request, context):  # noqa: N802
        v, w = command_of(request, context.invocation_metadata())
        if not (math.isfinite(v) and math.isfinite(w)):
            # one client's NaN must not break the robot every client shares: refused, and
            # the robot keeps the last accepted command
            with self._cond:
                self.requests.append((v, w, False))
            context.abort(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"velocity must be finite, got linear {request.linear!r}, "
                f"angular {request.angular!r}",
            )
        with self._cond:
            self.requests.append((v, w, self.manual_control))
            if not self.manual_control:
                return pb2.SetRobotVelocityResponse(result=pb2.Result(success=False))
            self.received.append((v, w))
            if self.mode == "lockstep":
                self._step(v, w)
            else:
                self._latest = (v, w, time.monotonic())
        return pb2.SetRobotVelocityResponse(result=pb2.Result(success=True))


def start_server(
    servicer: SimulatedKachaka, port: int = DEFAULT_PORT, host: str = "127.0.0.1"
) -> tuple[grpc.Server, int]:
    """Serve on host:port (0: a free port); returns (server, the port bound). ConfigError if
    the port cannot be bound (in use, or not allowed)."""
    server = grpc.server(
        ThreadPoolExecutor(max_workers=_WORKERS, thread_name_prefix="kachaka-api"),
        options=[("grpc.so_reuseport", 0)],  # a busy port is refused, not shared
    )
    add_KachakaApiServicer_to_server(servicer, server)
    try:
        bound = server.add_insecure_port(host_port(host, port))
    except RuntimeError as err:
        bound, reason = 0, str(err)
    else:
        reason = "in use or not allowed"
    if bound == 0:
        server.stop(None)
        raise ConfigError(f"--port {port}: cannot listen on {host}:{port} ({reason})")
    server.start()
    return server, bound


def host_port(host: str, port: int) -> str:
    """'HOST:PORT' for gRPC, an IPv6 address in brackets whether or not it came in them
    (``--host ::1`` and ``--host [::1]`` listen alike)."""
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    return f"[{bare}]:{port}" if ":" in bare else f"{bare}:{port}"
