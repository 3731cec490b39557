"""Scan filters of the kind real robots run before a local planner (beyond the paper, off by
default; docs/design/scan-filter.md#scan-filter).

A filter takes a :class:`~d3dwa_bullet.sim.scan.LaserScan` and returns one of the same shape,
so the simulator, ``drive`` and ``replay`` share it: it sits between the lidar and everything
that reads the scan (the observation, the planner, the recovery layer). Filters are chained by
name (:data:`SCAN_FILTERS`); a chain keeps its state per episode (:meth:`ScanFilter.reset`).

* ``median``: the per-beam median of the last ``window`` scans (3 by default: 0.3 s at 10 Hz),
  over the beams that returned a usable range (a beam with none in the window stays invalid).
  A phantom return or a dropout on one scan never reaches the planner alone, and the range
  noise of the nearest return, which a minimum over many beams pulls inward by about two
  standard deviations, shrinks. It lags a moving robot by half a window: 0.1 s, 3 cm at
  0.3 m/s.
* ``speckle``: drops a usable return whose two angular neighbours both differ from it by
  more than ``jump`` (an isolated return, as laser_filters' speckle filter does); a return
  at the edge of a real obstacle keeps a neighbour on it.

Pure numpy: no pybullet, no torch.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.sim.scan import LaserScan

MEDIAN_WINDOW = 3
"""Scans in the temporal median."""
SPECKLE_JUMP = 0.10
"""A return farther than this from both its neighbours is a speckle, m."""


class TemporalMedian:
    """Per-beam median over the last ``window`` scans of the usable returns."""

    def __init__(self, window: int = MEDIAN_WINDOW):
        if window < 1:
            raise ConfigError(f"median window must be >= 1, got {window!r}")
        self.window = window
        self._past: deque[np.ndarray] = deque(maxlen=window)

    def reset(self) -> None:
        self._past.clear()

    def __call__(self, scan: LaserScan) -> LaserScan:
        usable = np.where(scan.valid_mask(), scan.ranges, np.nan)
        if self._past and self._past[0].shape != usable.shape:
            self._past.clear()  # a scan of another beam count: start again
        self._past.append(usable)
        stack = np.stack(self._past)
        seen = np.isfinite(stack).any(axis=0)
        out = np.full(usable.shape, np.inf)  # no usable return in the window: out of range
        if seen.any():
            out[seen] = np.nanmedian(stack[:, seen], axis=0)
        return replace(scan, ranges=out)


class Speckle:
    """Drops usable returns farther than ``jump`` from both angular neighbours' returns."""

    def __init__(self, jump: float = SPECKLE_JUMP):
        if not jump > 0:
            raise ConfigError(f"speckle jump must be > 0 m, got {jump!r}")
        self.jump = jump

    def reset(self) -> None:
        pass

    def __call__(self, scan: LaserScan) -> LaserScan:
        r = np.where(scan.valid_mask(), scan.ranges, np.nan)
        if r.size < 3:
            return scan
        with np.errstate(invalid="ignore"):
            left = np.abs(r - np.roll(r, 1)) <= self.jump
            right = np.abs(r - np.roll(r, -1)) <= self.jump
        # the ends of a field of view under 360 degrees have one neighbour only
        left[0] = right[-1] = False
        lone = np.isfinite(r) & ~left & ~right
        if not lone.any():
            return scan
        out = scan.ranges.copy()
        out[lone] = np.inf
        return replace(scan, ranges=out)


#: Named chains, applied left to right. ``none`` is the paper's stack.
SCAN_FILTERS: dict[str, tuple[str, ...]] = {
    "none": (),
    "median": ("median",),
    "speckle": ("speckle",),
    "speckle+median": ("speckle", "median"),
}
_STAGES: dict[str, type[TemporalMedian] | type[Speckle]] = {
    "median": TemporalMedian,
    "speckle": Speckle,
}


@dataclass
class ScanFilter:
    """A named chain of scan filters with per-episode state."""

    name: str = "none"

    def __post_init__(self) -> None:
        check_scan_filter(self.name)
        self._stages: list[TemporalMedian | Speckle] = [
            _STAGES[s]() for s in SCAN_FILTERS[self.name]
        ]

    def reset(self) -> None:
        for stage in self._stages:
            stage.reset()

    def __call__(self, scan: LaserScan) -> LaserScan:
        for stage in self._stages:
            scan = stage(scan)
        return scan


def check_scan_filter(name: str) -> str:
    """The name, or ConfigError naming it and the known ones."""
    if name not in SCAN_FILTERS:
        raise ConfigError(f"unknown scan filter {name!r}; choose one of {', '.join(SCAN_FILTERS)}")
    return name


def check_driven_filter(trained: str, running: str, policy: str) -> None:
    """ConfigError (one line) when a policy trained behind the filter ``trained`` would be
    driven behind another one, ``running``: it learned on filtered scans, and the raw ones
    are not its input. A policy trained without a filter (the paper's) may be driven behind
    any (the filter applies to every method alike). ``policy`` names it in the message."""
    if trained != "none" and running != trained:
        raise ConfigError(
            f"{policy} was trained behind the scan filter {trained!r}; drive it with "
            f"--scan-filter {trained} (this run has {running!r})"
        )
