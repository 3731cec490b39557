"""The live robot (SPEC section 10, docs/design/live.md#live): the closed loop on the Kachaka API
(``drive``), its safety (``safety``: clamp, staleness, watchdog), the client adapter
(``link``), the message conversions (``messages``), a live run as a bag (``recording``) and
the simulated Kachaka behind the same service (``sim_robot``, ``d3dwa serve``).

Needs the ``robot`` extra (kachaka-api, grpcio): ``pip install "d3dwa-bullet[robot]"``. Nothing
outside this package imports it at module level, so the base install imports everything else.
"""

from d3dwa_bullet.live.drive import DriveResult, DriveSettings, drive, warm_up
from d3dwa_bullet.live.link import DEFAULT_PORT, KachakaLink, Reading
from d3dwa_bullet.live.recording import DriveRecorder
from d3dwa_bullet.live.safety import KACHAKA_LIMITS, Freshness, SpeedLimits, Watchdog
from d3dwa_bullet.live.sim_robot import MODES, SimulatedKachaka, start_server

__all__ = [
    "DEFAULT_PORT",
    "KACHAKA_LIMITS",
    "MODES",
    "DriveRecorder",
    "DriveResult",
    "DriveSettings",
    "Freshness",
    "KachakaLink",
    "Reading",
    "SimulatedKachaka",
    "SpeedLimits",
    "Watchdog",
    "drive",
    "start_server",
    "warm_up",
]
