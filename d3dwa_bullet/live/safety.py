"""What keeps the live loop safe besides its ``finally: stop``: the command clamp, the
staleness check of what the robot serves, the contract its sensors started with (the scan's
layout and readings, odometry that makes physical sense), and a watchdog thread that stops
the robot when the loop itself stalls (docs/design/live.md#live).

The exits they add to the loop's own (goal, collision, timeout, an error, Ctrl-C) all end
where every exit ends: in ``set_robot_stop``.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from d3dwa_bullet.errors import ConfigError, RobotLinkError, ScanError
from d3dwa_bullet.live.link import Reading
from d3dwa_bullet.params import ObservationParams
from d3dwa_bullet.planning.observation import sector_ranges
from d3dwa_bullet.sim.scan import LaserScan, Pose2D, scan_points_body

KACHAKA_LIMITS = (0.3, 1.57)
"""The Kachaka API's velocity limits (kachaka_api.base MAX_LINEAR/ANGULAR_VELOCITY): m/s, rad/s."""


@dataclass(frozen=True)
class SpeedLimits:
    """What a command may ask of the robot: |v| <= v_max (m/s), |w| <= w_max (rad/s)."""

    v_max: float = KACHAKA_LIMITS[0]
    w_max: float = KACHAKA_LIMITS[1]

    def __post_init__(self) -> None:
        for name in ("v_max", "w_max"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"speed limit {name} must be a number > 0, got {value!r}")

    def clamp(self, v: float, w: float) -> tuple[float, float]:
        """(v, w) clipped to the limits; a non-finite value is a stop of that component."""
        v = min(max(v, -self.v_max), self.v_max) if math.isfinite(v) else 0.0
        w = min(max(w, -self.w_max), self.w_max) if math.isfinite(w) else 0.0
        return v, w


class Freshness:
    """Refuses readings older than ``limit_s`` (two control periods by default).

    A stream is stale when its stamp has not advanced for ``limit_s``, or when it lags the
    newest stream by more than ``limit_s`` on the robot's own clock (one stream stopped while
    another runs). "Has not advanced for" is counted on the loop's clock, ``now``:

    - realtime (``period_s`` None): this machine's monotonic clock, s;
    - lockstep (``period_s``: the control period, s): the control periods the robot has been
      advanced, i.e. the commands sent. Every command steps a lockstep robot one period, and
      every stream must advance with it; the wall says nothing there (a lockstep step takes a
      few ms on a fast machine, so 0.2 s of wall would pass only after a hundred frozen
      stamps, and sooner on a slow one). A stamp unchanged over more than
      ``limit_s / period_s`` periods (2 by default: stopped at the third) is stale.

    The robot's clock is never compared with this machine's: they need not be synchronised,
    and a lockstep simulator's clock does not follow the wall at all.
    """

    def __init__(self, limit_s: float, period_s: float | None = None) -> None:
        if not (math.isfinite(limit_s) and limit_s > 0):
            raise ConfigError(f"staleness limit must be a number of seconds > 0, got {limit_s!r}")
        if period_s is not None and not (math.isfinite(period_s) and period_s > 0):
            raise ConfigError(f"control period must be a number of seconds > 0, got {period_s!r}")
        self.limit_s = limit_s
        self.limit_periods = None if period_s is None else round(limit_s / period_s, 9)
        """Lockstep: control periods a stamp may stay unchanged (None: realtime)."""
        self._last: dict[str, tuple[int, float]] = {}  # stream -> (stamp ns, now when it changed)

    def check(self, stamps: dict[str, int], now: float, where: str) -> None:
        """stamps: stream name -> its stamp (int ns, robot clock); now: monotonic s in
        realtime, control periods advanced (commands sent) in lockstep. RobotLinkError naming
        the stream if one is stale."""
        newest_name = max(stamps, key=stamps.__getitem__)
        newest = stamps[newest_name]
        for name, stamp in stamps.items():
            last = self._last.get(name)
            if last is not None and stamp < last[0]:
                raise RobotLinkError(
                    f"{where}: the {name} stamp went back in time ({stamp} < {last[0]} ns)"
                )
            if newest - stamp > self.limit_s * 1e9:  # first: it names the stream still running
                raise RobotLinkError(
                    f"{where}: stale {name}: {(newest - stamp) / 1e9:.2f} s older than the "
                    f"{newest_name} (limit {self.limit_s:g} s)"
                )
            if last is None or stamp != last[0]:
                self._last[name] = (stamp, now)
            else:
                self._check_unchanged(name, now - last[1], where)

    def _check_unchanged(self, name: str, unchanged: float, where: str) -> None:
        if self.limit_periods is None:
            if unchanged > self.limit_s:
                raise RobotLinkError(
                    f"{where}: stale {name}: its stamp has not changed for "
                    f"{unchanged:.2f} s (limit {self.limit_s:g} s)"
                )
        elif unchanged > self.limit_periods:
            raise RobotLinkError(
                f"{where}: stale {name}: its stamp has not changed over {unchanged:g} control "
                f"periods in lockstep, where each command advances the robot one (limit "
                f"{self.limit_periods:g}, {self.limit_s:g} s)"
            )


MIN_READING_FRACTION = 0.5
"""A scan is *blind* when fewer than this fraction of its beams read, or when an observation
sector holds no beam that reads. A beam reads when it returns a range within [range_min,
range_max], or REP-117's +inf (nothing within range) or -inf (too close); NaN, 0, negative
and other out-of-range values read nothing. The simulated lidar reads on every beam, the
``harsh`` profile's dropouts blank about 5 % of them."""
BLIND_SCANS = 3
"""Blind scans in a row that end a run (0.3 s at 10 Hz). The loop never decides on a blind
scan: it sends a zero command (the robot holds still) and reads the next one."""
LAYOUT_TOLERANCE = 1e-6
"""How far a scan's angles (rad) and range limits (m) may drift from the first scan's."""
ODOMETRY_SPEED_FACTOR = 2.0
"""Odometry may move at most this many times the robot's speed limits between two readings
(and report a twist within them), plus ``ODOMETRY_SLACK``."""
ODOMETRY_SLACK = (0.5, 0.5)
"""m, rad: what a fused estimate may jump on a correction beyond that (the ``harsh``
profile's map fixes move the simulated estimate by up to 0.21 m and 0.16 rad in one step)."""


def reading_mask(scan: LaserScan) -> np.ndarray:
    """(N,) bool: the beams that read (see ``MIN_READING_FRACTION``)."""
    return scan.valid_mask() | np.isinf(scan.ranges)


def empty_sectors(
    scan: LaserScan, reads: np.ndarray, mount: Pose2D, obs: ObservationParams
) -> np.ndarray:
    """Indices of the observation sectors that none of the beams ``reads`` ((N,) bool) falls
    in: the observation would read free space there, whatever is in front of the robot."""
    reach = min(scan.range_max, obs.d_max)
    probe = replace(scan, ranges=np.where(reads, reach, np.nan), range_min=0.0)
    return np.flatnonzero(~np.isfinite(sector_ranges(scan_points_body(probe, mount), obs)))


def _layout(scan: LaserScan) -> tuple[int, float, float, float, float]:
    """(beams, first angle rad, last angle rad, range_min m, range_max m)."""
    n = scan.ranges.size
    last = scan.angle_min + (n - 1) * scan.angle_increment
    return n, scan.angle_min, last, scan.range_min, scan.range_max


class ScanContract:
    """What the robot's first scan promised, held against every later scan.

    Layout: the same beam count, first and last beam angle (the field of view) and range
    limits (to ``LAYOUT_TOLERANCE``); a change is a ScanError at once. Readings: a blind scan
    (``MIN_READING_FRACTION``) is never decided on; ``BLIND_SCANS`` of them in a row are a
    ScanError. ``check`` returns why a scan is blind, or None.
    """

    def __init__(self, first: LaserScan, mount: Pose2D, obs: ObservationParams) -> None:
        self.layout = _layout(first)
        self.mount, self.obs = mount, obs
        self.blind = 0
        """Blind scans in a row so far."""

    def check(self, scan: LaserScan) -> str | None:
        self._check_layout(scan)
        reads = reading_mask(scan)
        reason = None
        if reads.mean() < MIN_READING_FRACTION:
            reason = f"{int(reads.sum())} of {reads.size} beams read"
        else:
            empty = empty_sectors(scan, reads, self.mount, self.obs)
            if empty.size:
                reason = f"no beam reads in sector(s) {', '.join(map(str, empty))}"
        self.blind = self.blind + 1 if reason is not None else 0
        if self.blind >= BLIND_SCANS:
            raise ScanError(
                f"the robot's scan is blind for {self.blind} scans in a row (at stamp "
                f"{scan.stamp_ns} ns: {reason}; a scan must read on >= "
                f"{MIN_READING_FRACTION:.0%} of its beams and in each of the "
                f"{self.obs.sectors} observation sectors); refusing to drive blind"
            )
        return reason

    def _check_layout(self, scan: LaserScan) -> None:
        have, want = _layout(scan), self.layout
        names = ("beams", "first angle", "last angle", "range_min", "range_max")
        for name, got, first in zip(names, have, want, strict=True):
            if abs(got - first) > LAYOUT_TOLERANCE:
                raise ScanError(
                    f"the robot's scan changed its layout mid-run (at stamp {scan.stamp_ns} "
                    f"ns): {name} {got:.6g}, was {first:.6g} at the start; refusing to drive "
                    "on a lidar that no longer meets its first scan's contract"
                )


class OdometryCheck:
    """Odometry that makes physical sense, or a RobotLinkError naming what does not.

    Every served number finite (fused odometry, wheel odometry, gyro); the fused twist
    within ``ODOMETRY_SPEED_FACTOR`` x (v_max, w_max); and between two readings the pose may
    move at most that speed over the time between their stamps, plus ``ODOMETRY_SLACK``.
    """

    def __init__(self, v_max: float, w_max: float) -> None:
        self.v_max = ODOMETRY_SPEED_FACTOR * v_max
        self.w_max = ODOMETRY_SPEED_FACTOR * w_max
        self._last: tuple[tuple[float, float, float], int] | None = None

    def check(self, reading: Reading, where: str) -> None:
        odom = reading.odometry
        values = {"odometry pose": odom.pose, "odometry twist": odom.twist}
        if reading.wheel is not None:
            values |= {"wheel odometry pose": reading.wheel.pose}
            values |= {"wheel odometry twist": reading.wheel.twist}
        if reading.imu_w is not None:
            values["gyro yaw rate"] = (reading.imu_w,)
        for name, value in values.items():
            if not all(math.isfinite(x) for x in value):
                raise RobotLinkError(f"{where} serves a non-finite {name} {tuple(value)}")
        v, w = odom.twist
        if abs(v) > self.v_max or abs(w) > self.w_max:
            raise RobotLinkError(
                f"{where} serves an odometry twist ({v:.3g} m/s, {w:.3g} rad/s) beyond "
                f"{self.v_max:g} m/s, {self.w_max:g} rad/s, which the robot cannot reach"
            )
        if self._last is not None:
            (x0, y0, t0), stamp0 = self._last
            dt = max(odom.stamp_ns - stamp0, 0) / 1e9
            moved = math.hypot(odom.pose[0] - x0, odom.pose[1] - y0)
            turned = abs(math.remainder(odom.pose[2] - t0, math.tau))
            move_max = self.v_max * dt + ODOMETRY_SLACK[0]
            turn_max = self.w_max * dt + ODOMETRY_SLACK[1]
            if moved > move_max or turned > turn_max:
                raise RobotLinkError(
                    f"{where} serves odometry that jumped {moved:.3g} m and {turned:.3g} rad "
                    f"in {dt:.3g} s (at most {move_max:.3g} m and {turn_max:.3g} rad are "
                    "possible)"
                )
        self._last = (odom.pose, odom.stamp_ns)


class Watchdog:
    """A thread that calls ``stop`` once if ``beat`` is not called for ``timeout_s``.

    Commands go through :meth:`send`, which holds the same lock as the watchdog's firing: once
    it has fired no command is sent any more (:attr:`fired` is set and :meth:`send` raises),
    so its stop is the robot's last command.
    """

    def __init__(self, timeout_s: float, stop: Callable[[], object]) -> None:
        if not (math.isfinite(timeout_s) and timeout_s > 0):
            raise ConfigError(f"--watchdog must be a number of seconds > 0, got {timeout_s!r}")
        self.timeout_s, self._stop = timeout_s, stop
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._last = time.monotonic()
        self.fired = False
        """True once the watchdog has stopped the robot."""
        self._thread = threading.Thread(target=self._watch, name="drive-watchdog", daemon=True)

    def start(self) -> Watchdog:
        self._last = time.monotonic()
        self._thread.start()
        return self

    def beat(self) -> None:
        """The loop is alive."""
        self._last = time.monotonic()

    def send(self, command: Callable[..., object], *args: object) -> None:
        """Run command(*args) unless the watchdog has fired (then RobotLinkError)."""
        with self._lock:
            if self.fired:
                raise self.error()
            command(*args)

    def error(self) -> RobotLinkError:
        return RobotLinkError(
            f"the control loop stalled for more than {self.timeout_s:g} s; "
            "the watchdog stopped the robot"
        )

    def _watch(self) -> None:
        while not self._done.wait(self.timeout_s / 4):
            if time.monotonic() - self._last > self.timeout_s:
                with self._lock:
                    self.fired = True
                self._stop()
                return

    def close(self) -> None:
        self._done.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[threading.Event]:
    """Ctrl-C (SIGINT) and SIGTERM set the yielded event instead of raising wherever the
    loop happens to be, so the loop ends at a step boundary: never between a command and its
    record. A second signal raises KeyboardInterrupt at once (the loop's ``finally`` still
    stops the robot). Outside the main thread, signals stay as they are."""
    event = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield event
        return

    def defer(signum: int, frame: object) -> None:
        if event.is_set():
            raise KeyboardInterrupt
        event.set()

    previous = {sig: signal.signal(sig, defer) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield event
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
