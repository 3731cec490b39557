"""Lidar parameters of a randomisation profile, estimated from a robot's recorded scans.

Readings are classified and binned into the observation's sectors by
:mod:`transfer.compare` (``classify_readings``, ``beam_sectors``): one classifier for the
whole package. Estimators (``S`` scans of ``N`` beams, one bag at a time, then pooled):

* **range_std**: on *stationary* scan pairs, the differences of beams valid in both,
  ``difference_noise_std`` (1.4826 MAD / sqrt 2). A pair is stationary when the odometry
  (the bag's pose source) says the robot stood still at both scans, or, without odometry,
  when the beam-by-beam differences of two consecutive scans are white noise (motion makes
  them smooth along the scan and large).
  With fewer than ``MIN_STATIONARY_PAIRS`` such pairs: the **line-fit fallback**, residuals of
  each valid beam's range against the line through its two valid neighbours' points (a local
  3-beam line fit, residual variance about 1.5 sigma^2), robust std; a note says so.
* **dropout per sector and its kind mix**: among beams valid in the scans before and after,
  the fraction invalid in the scan between (a persistent +inf is open space, not a dropout);
  the classes of those readings give the NaN / +inf / -inf / 0.0 / out-of-range mix.
* **spurious returns**: a lone valid reading, shorter by max(0.15 m, 20 %) than the agreeing
  readings of the same beam before and after, and by 0.15 m than its angular neighbours (an
  object edge spans beams, a phantom is one beam). Only in front of surfaces: +inf on both
  sides is as likely two dropouts as open space, and the rate is per beam either way.
  Phantoms close to the true range cannot be seen, so the count is divided by each
  candidate's chance of detection for a phantom uniform on [min, max] of the detected
  values, and by the chance the phantom was not dropped afterwards.
* **sensor** (informational): beam count, field of view (angle_max - angle_min), increment,
  range limits, scan rate (1 / median scan interval).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import median_abs_deviation

from d3dwa_bullet.errors import BagFormatError
from d3dwa_bullet.params import ObservationParams
from d3dwa_bullet.sim.noise_config import SECTOR_DROPOUT_KINDS
from transfer.bag_reader import BagData
from transfer.compare import READING_CLASSES, beam_sectors, classify_readings, difference_noise_std

#: Scans a bag set needs before anything is estimated.
MIN_SCANS = 10
#: Stationary consecutive-scan pairs needed for the stationary range-noise estimate.
MIN_STATIONARY_PAIRS = 5
#: Valid beam triples needed for the line-fit fallback.
MIN_LINE_TRIPLES = 500
#: Odometry speeds below which the robot stands still: m/s, rad/s.
STILL_SPEED = (0.005, 0.01)
#: Without odometry, a pair is still if its beam differences are white: their spread is at
#: most this multiple of the spread their beam-to-beam roughness implies (motion makes them
#: smooth and large: ratios of 2-5), or below the floor (m). Slow motion along walls can pass
#: for standing still, but then it inflates the noise estimate by at most this ratio - 1.
STILL_RATIO, STILL_FLOOR = 1.1, 0.001
#: Dropouts a sector needs for its own kind mix (else the mix over all sectors).
MIN_SECTOR_DROPOUTS = 20
#: Phantoms needed to estimate their range (else spurious_min / max stay the base's).
MIN_PHANTOMS = 10
#: A phantom is shorter than the same beam before and after by max(margin, fraction x their
#: range), and differs by the margin (m) from its angular neighbours; the readings before and
#: after agree within the margin. (Grazing walls seen while driving change by a few % a scan.)
PHANTOM_MARGIN, PHANTOM_FRACTION = 0.15, 0.2
#: The line-fit residual r_i - (r_{i-1} + r_{i+1}) / 2 has variance 1.5 sigma^2.
CHORD_VARIANCE = 1.5
OBSERVATION = ObservationParams()
assert READING_CLASSES == SECTOR_DROPOUT_KINDS  # one order of kinds for reading and writing


@dataclass(frozen=True)
class Estimate:
    """One profile value and how it was obtained (a line for the profile's comment)."""

    value: Any
    how: str


@dataclass
class ScanCalibration:
    """What the scans say: ``estimates['lidar.range_std'] = Estimate(...)`` and the sensor."""

    scans: int
    estimates: dict[str, Estimate]
    sensor: dict[str, Any]
    sectors: list[dict[str, Any]]
    """Per observation sector: candidates, dropouts, rate, kind counts (for reports)."""
    notes: list[str] = field(default_factory=list)


@dataclass
class _Pooled:
    still_diffs: list[np.ndarray] = field(default_factory=list)
    chord: list[np.ndarray] = field(default_factory=list)
    still_pairs: int = 0
    still_source: set[str] = field(default_factory=set)
    candidates: np.ndarray = field(default_factory=lambda: np.zeros(OBSERVATION.sectors))
    kinds: np.ndarray = field(default_factory=lambda: np.zeros((OBSERVATION.sectors, 5)))
    phantoms: list[np.ndarray] = field(default_factory=list)
    phantom_refs: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    intervals: list[np.ndarray] = field(default_factory=list)
    geometry: Counter = field(default_factory=Counter)


def _robust_std(x: np.ndarray) -> float:
    return float(median_abs_deviation(x, scale="normal")) if x.size >= 2 else math.nan


def _chord_residuals(r: np.ndarray, valid: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(S, N) ranges -> for every beam valid with both its neighbours, its range minus the
    range at which its ray meets the line through the neighbours' points (a local line fit
    in the plane: no bias on flat surfaces, whatever the incidence)."""
    ok = valid[:, 1:-1] & valid[:, :-2] & valid[:, 2:]
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(invalid="ignore", divide="ignore"):
        x, y = r * c, r * s
        x1, y1, x3, y3 = x[:, :-2], y[:, :-2], x[:, 2:], y[:, 2:]
        dx, dy = x3 - x1, y3 - y1
        t = (x1 * dy - y1 * dx) / (c[1:-1] * dy - s[1:-1] * dx)
        e = r[:, 1:-1] - t
    return e[ok & np.isfinite(e)]


def _still_pairs(
    bag: BagData, times: np.ndarray, r: np.ndarray, valid: np.ndarray
) -> tuple[np.ndarray, str]:
    """(S-1,) bool: consecutive scan pairs taken while the robot stood still, and how."""
    odom = bag.odometry
    if odom is not None and len(odom) >= 2:
        pose, twist, where = odom.at(times)
        still = (
            (np.abs(twist[:, 0]) < STILL_SPEED[0])
            & (np.abs(twist[:, 1]) < STILL_SPEED[1])
            & (where == 0)
        )
        return still[1:] & still[
            :-1
        ], f"odometry {bag.topics['odometry'] or bag.topics['wheel_odometry']}"
    pairs = np.zeros(max(len(times) - 1, 0), dtype=bool)
    for k in range(pairs.size):
        with np.errstate(invalid="ignore"):  # inf - inf on invalid beams, masked
            d = np.where(valid[k] & valid[k + 1], r[k + 1] - r[k], np.nan)
        d2 = d[:-2] - 2.0 * d[1:-1] + d[2:]  # white noise: variance 6 var(d); motion: ~0
        whole = _robust_std(d[np.isfinite(d)])
        white = _robust_std(d2[np.isfinite(d2)]) / math.sqrt(6.0)
        pairs[k] = whole <= STILL_FLOOR or whole <= STILL_RATIO * white
    return pairs, "scan-to-scan change (no odometry)"


def _add_bag(bag: BagData, pooled: _Pooled, notes: list[str]) -> None:
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(bag.scans):
        key = (s.ranges.size, s.angle_min, s.angle_increment, s.range_min, s.range_max)
        groups.setdefault(key, []).append(i)
    key, index = max(groups.items(), key=lambda kv: len(kv[1]))
    if len(groups) > 1:
        notes.append(
            f"{bag.path}: scans of {len(groups)} geometries; using the {len(index)} scans of "
            f"the most common ({key[0]} beams), leaving out {len(bag.scans) - len(index)}"
        )
    pooled.geometry[key] += len(index)
    times = bag.scan_times_ns[index]
    pooled.intervals.append(np.diff(times) / 1e9)
    first = bag.scans[index[0]]
    r = np.stack([bag.scans[i].ranges for i in index])
    masks = classify_readings(r, first.range_min, first.range_max)
    valid = masks["valid"]
    sector = beam_sectors(first, bag.mount, OBSERVATION)

    still, source = _still_pairs(bag, times, r, valid)
    pooled.still_pairs += int(still.sum())
    if still.any():
        pooled.still_source.add(source)
        both = valid[1:] & valid[:-1] & still[:, None]
        with np.errstate(invalid="ignore"):
            pooled.still_diffs.append((r[1:] - r[:-1])[both])
    pooled.chord.append(_chord_residuals(r, valid, first.angles))

    if len(index) < 3:
        return
    before, now, after = slice(0, -2), slice(1, -1), slice(2, None)
    cand = valid[before] & valid[after]
    in_fov = sector >= 0
    one_hot = np.equal.outer(sector, np.arange(OBSERVATION.sectors)).astype(float)  # (N, K)
    pooled.candidates += (cand & in_fov).sum(axis=0) @ one_hot
    for c, name in enumerate(READING_CLASSES):
        pooled.kinds[:, c] += (cand & masks[name][now] & in_fov).sum(axis=0) @ one_hot

    ra, rb, rk = r[before], r[after], r[now]
    with np.errstate(invalid="ignore"):
        agree = cand & (np.abs(ra - rb) < PHANTOM_MARGIN)
        ref = np.where(agree, 0.5 * (ra + rb), np.inf)
    # Only in front of a surface: +inf on both sides is as often two dropouts as open space.
    pooled.phantom_refs.append((ref[agree], np.broadcast_to(sector, ref.shape)[agree]))
    # ... and alone in its scan: an object edge spans beams, a phantom is one beam.
    pad = np.full((rk.shape[0], 1), np.inf)
    with np.errstate(invalid="ignore"):
        left = np.abs(rk - np.hstack((pad, rk[:, :-1]))) > PHANTOM_MARGIN
        right = np.abs(rk - np.hstack((rk[:, 1:], pad))) > PHANTOM_MARGIN
        hit = agree & valid[now] & (rk < ref - _shortfall(ref)) & left & right
    pooled.phantoms.append(rk[hit])


def calibrate_scans(bags: list[BagData]) -> ScanCalibration:
    """Estimate the lidar parameters from the scans of ``bags`` (module docstring).

    Raises ``BagFormatError`` with fewer than ``MIN_SCANS`` scans in all, or when neither
    enough stationary pairs nor enough valid beam triples exist for the range noise.
    """
    total = sum(len(b.scans) for b in bags)
    names = ", ".join(str(b.path) for b in bags)
    if total < MIN_SCANS:
        raise BagFormatError(
            f"{names}: {total} scan(s); calibrate needs at least {MIN_SCANS} scans "
            f"(and {MIN_STATIONARY_PAIRS + 1} consecutive ones with the robot standing still "
            "for the best range-noise estimate)"
        )
    pooled, notes = _Pooled(), []
    for bag in bags:
        _add_bag(bag, pooled, notes)
    est: dict[str, Estimate] = {}
    est["lidar.range_std"] = _range_noise(pooled, names, notes)
    drop = _dropout(pooled, est)
    _spurious(pooled, est, drop)
    sensor = _sensor(pooled)
    sectors = [
        {
            "sector": k,
            "candidates": int(pooled.candidates[k]),
            "dropouts": int(pooled.kinds[k].sum()),
            "rate": float(drop[k]),
            **{name: int(pooled.kinds[k, c]) for c, name in enumerate(READING_CLASSES)},
        }
        for k in range(OBSERVATION.sectors)
    ]
    return ScanCalibration(total, est, sensor, sectors, notes)


def _range_noise(pooled: _Pooled, names: str, notes: list[str]) -> Estimate:
    if pooled.still_pairs >= MIN_STATIONARY_PAIRS:
        d = np.concatenate(pooled.still_diffs)
        std = difference_noise_std(d)
        how = ", ".join(sorted(pooled.still_source))
        return Estimate(
            round(float(std or 0.0), 5),
            f"stationary-scan differences over {pooled.still_pairs} scan pairs "
            f"({d.size} beam pairs; still from {how})",
        )
    e = np.concatenate(pooled.chord) if pooled.chord else np.zeros(0)
    if e.size < MIN_LINE_TRIPLES:
        raise BagFormatError(
            f"{names}: cannot estimate the range noise: {pooled.still_pairs} stationary scan "
            f"pair(s) (need {MIN_STATIONARY_PAIRS}, i.e. {MIN_STATIONARY_PAIRS + 1} consecutive "
            f"scans standing still) and {e.size} valid beam triples for line fits (need "
            f"{MIN_LINE_TRIPLES})"
        )
    std = _robust_std(e) / math.sqrt(CHORD_VARIANCE)
    notes.append(
        f"the robot never stands still long enough ({pooled.still_pairs} stationary scan pairs, "
        f"need {MIN_STATIONARY_PAIRS}): range noise from line-fit residuals instead"
    )
    return Estimate(
        round(std, 5), f"line-fit residuals (3-beam chords) over {e.size} beam triples; the "
        "robot never stood still"
    )  # fmt: skip


def _proportions(p: np.ndarray, digits: int = 4) -> list[float]:
    """Proportions rounded for the file, still summing to 1 (the largest takes the rest)."""
    out = np.round(p, digits)
    i = int(np.argmax(out))
    out[i] = round(1.0 - (out.sum() - out[i]), digits)
    return [float(v) for v in out]


def _dropout(pooled: _Pooled, est: dict[str, Estimate]) -> np.ndarray:
    cand, kinds = pooled.candidates, pooled.kinds
    dropped = kinds.sum(axis=1)
    rate = np.divide(dropped, cand, out=np.zeros_like(dropped), where=cand > 0)
    n_cand, n_drop = int(cand.sum()), int(dropped.sum())
    if n_cand == 0:
        return rate
    mean = n_drop / n_cand
    how = (
        f"invalid readings between two valid ones of the same beam: {n_drop} of {n_cand} "
        "beams in the field of view"
    )
    est["lidar.dropout_prob"] = Estimate(round(mean, 5), how)
    if n_drop == 0:
        return rate
    scale = np.where(cand > 0, rate / mean, 1.0)
    est["lidar.dropout_sector_scale"] = Estimate(
        [round(float(s), 4) for s in scale],
        "per-sector rate / dropout_prob, right to left: "
        + ", ".join(f"{100 * p:.1f}%" for p in rate),
    )
    overall = kinds.sum(axis=0) / n_drop
    rows, own = [], 0
    for k in range(kinds.shape[0]):
        if dropped[k] >= MIN_SECTOR_DROPOUTS:
            rows.append(kinds[k] / dropped[k])
            own += 1
        else:
            rows.append(overall)
    rows = [_proportions(row) for row in rows]
    est["lidar.dropout_sector_kinds"] = Estimate(
        rows,
        f"classes of those readings (NaN, +inf, -inf, 0.0, out of range); {own} of "
        f"{len(rows)} sectors from their own dropouts, the rest (< {MIN_SECTOR_DROPOUTS}) "
        "from all sectors'",
    )
    return rate


def _shortfall(ref: np.ndarray) -> np.ndarray:
    """How much shorter than the surrounding readings (m) a phantom must be."""
    return np.maximum(PHANTOM_MARGIN, PHANTOM_FRACTION * ref)


def _spurious(pooled: _Pooled, est: dict[str, Estimate], drop: np.ndarray) -> None:
    if not pooled.phantom_refs:
        return
    ref = np.concatenate([r for r, _ in pooled.phantom_refs])
    sec = np.concatenate([s for _, s in pooled.phantom_refs])
    values = np.concatenate(pooled.phantoms)
    n = values.size
    kept = 1.0 - np.where(sec >= 0, drop[np.maximum(sec, 0)], drop.mean())
    if n == 0:
        est["lidar.spurious_prob"] = Estimate(
            0.0, f"no phantom short return among {ref.size} candidate readings"
        )
        return
    lo, hi = float(values.min()), float(values.max())
    if n >= MIN_PHANTOMS and hi > lo:
        detect = np.clip((ref - _shortfall(ref) - lo) / (hi - lo), 0.0, 1.0)
        est["lidar.spurious_min"] = Estimate(round(lo, 4), f"shortest of {n} phantom returns")
        est["lidar.spurious_max"] = Estimate(round(hi, 4), f"longest of {n} phantom returns")
    else:
        detect = np.ones_like(ref)
    expected = float((detect * kept).sum())
    est["lidar.spurious_prob"] = Estimate(
        round(n / expected, 6) if expected > 0 else 0.0,
        f"{n} lone valid readings shorter by > max({PHANTOM_MARGIN} m, {PHANTOM_FRACTION:.0%}) "
        "than the same beam before and after, "
        f"over {expected:.0f} detectable candidates",
    )


def _sensor(pooled: _Pooled) -> dict[str, Any]:
    (beams, a0, inc, rmin, rmax), count = pooled.geometry.most_common(1)[0]
    intervals = np.concatenate(pooled.intervals) if pooled.intervals else np.zeros(0)
    intervals = intervals[intervals > 0]
    rate = 1.0 / float(np.median(intervals)) if intervals.size else None
    return {
        "beams": int(beams),
        "fov_deg": round(math.degrees(abs(inc) * (beams - 1)), 3),
        "angle_min_deg": round(math.degrees(a0), 3),
        "increment_deg": round(math.degrees(inc), 5),
        "range_min": round(float(rmin), 4),
        "range_max": round(float(rmax), 4),
        "scan_rate_hz": None if rate is None else round(rate, 3),
        "scans": int(count),
    }
