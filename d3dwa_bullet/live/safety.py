"""What keeps the live loop safe besides its ``finally: stop``: the command clamp, the
staleness check of what the robot serves, and a watchdog thread that stops the robot when
the loop itself stalls (docs/design.md#live).

The three exits they add to the loop's own (goal, collision, timeout, an error, Ctrl-C) all
end where every exit ends: in ``set_robot_stop``.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from d3dwa_bullet.errors import ConfigError, RobotLinkError

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

    A stream is stale when its stamp has not advanced for ``limit_s`` of this machine's
    monotonic clock, or when it lags the newest stream by more than ``limit_s`` on the
    robot's own clock (one stream stopped while another runs). The robot's clock is never
    compared with this machine's: they need not be synchronised, and a lockstep simulator's
    clock does not follow the wall at all.
    """

    def __init__(self, limit_s: float) -> None:
        if not (math.isfinite(limit_s) and limit_s > 0):
            raise ConfigError(f"staleness limit must be a number of seconds > 0, got {limit_s!r}")
        self.limit_s = limit_s
        self._last: dict[str, tuple[int, float]] = {}  # stream -> (stamp ns, when it changed)

    def check(self, stamps: dict[str, int], now: float, where: str) -> None:
        """stamps: stream name -> its stamp (int ns, robot clock); now: monotonic s.
        RobotLinkError naming the stream if one is stale."""
        newest_name = max(stamps, key=stamps.__getitem__)
        newest = stamps[newest_name]
        for name, stamp in stamps.items():
            last = self._last.get(name)
            if last is not None and stamp < last[0]:
                raise RobotLinkError(
                    f"{where}: the {name} stamp went back in time ({stamp} < {last[0]} ns)"
                )
            if last is None or stamp != last[0]:
                self._last[name] = (stamp, now)
            elif now - last[1] > self.limit_s:
                raise RobotLinkError(
                    f"{where}: stale {name}: its stamp has not changed for "
                    f"{now - last[1]:.2f} s (limit {self.limit_s:g} s)"
                )
            if newest - stamp > self.limit_s * 1e9:
                raise RobotLinkError(
                    f"{where}: stale {name}: {(newest - stamp) / 1e9:.2f} s older than the "
                    f"{newest_name} (limit {self.limit_s:g} s)"
                )


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
