"""Side-by-side lidar statistics of two bags (e.g. a simulated recording and a real one).

Beams are binned into the observation's sectors (K = 8 slices of the 240 deg field of view,
right to left, in base_link) by their direction: beam angle plus the lidar's mounting yaw.
(The observation bins returned *points* seen from base_link; for the 0.156 m lidar offset
the two differ only for returns closer than a few decimetres near sector borders, and a
direction is the only place an invalid beam can be binned.)

Each reading falls in exactly one class (REP-117 plus what real drivers emit):
valid (finite, > 0, in [range_min, range_max]), ``nan``, ``pos_inf``, ``neg_inf``, ``zero``
(0.0) and ``out_of_range`` (any other finite value outside [range_min, range_max]).

Scan messages that cannot become a scan (zero beams, invalid geometry, corrupt) are left out
and counted by reason in ``skipped``; the table says so above its rows.

Range noise: for each beam valid in two consecutive scans, d = r[k+1] - r[k]; the noise
estimate is 1.4826 * MAD(d) / sqrt(2), the standard deviation of one reading if the scene
and the robot stand still (the MAD ignores the few large jumps that motion and edges give).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from d3dwa_bullet.geometry import wrap_angles
from d3dwa_bullet.params import ObservationParams
from d3dwa_bullet.sim.scan import LaserScan, Pose2D
from transfer.bag_reader import read_bag
from transfer.topics import TopicMap

READING_CLASSES = ("nan", "pos_inf", "neg_inf", "zero", "out_of_range")
_MAD_TO_STD = 1.4826
DEFAULT_OBSERVATION = ObservationParams()


def classify_readings(
    ranges: np.ndarray, range_min: float, range_max: float
) -> dict[str, np.ndarray]:
    """Boolean masks, same shape as ranges, for 'valid' and each of ``READING_CLASSES``."""
    r = np.asarray(ranges, dtype=np.float64)
    finite = np.isfinite(r)
    zero = r == 0.0
    with np.errstate(invalid="ignore"):
        inside = (r >= range_min) & (r <= range_max)
    return {
        "valid": finite & ~zero & inside,
        "nan": np.isnan(r),
        "pos_inf": np.isposinf(r),
        "neg_inf": np.isneginf(r),
        "zero": zero,
        "out_of_range": finite & ~zero & ~inside,
    }


def beam_sectors(scan: LaserScan, mount: Pose2D, params: ObservationParams) -> np.ndarray:
    """(N,) int: each beam's sector in base_link, -1 outside the field of view."""
    ang = wrap_angles(scan.angles + mount.yaw)
    half = 0.5 * params.fov
    width = params.fov / params.sectors
    idx = np.minimum(np.floor((ang + half) / width).astype(np.intp), params.sectors - 1)
    return np.where((ang >= -half) & (ang <= half), idx, -1)


def difference_noise_std(diffs: np.ndarray) -> float | None:
    """Std of one reading from differences of two readings of the same thing:
    ``1.4826 * MAD(d) / sqrt(2)`` (None with fewer than two differences)."""
    if diffs.size < 2:
        return None
    mad = float(np.median(np.abs(diffs - np.median(diffs))))
    return _MAD_TO_STD * mad / math.sqrt(2.0)


def scan_statistics(
    bag_path: str | Path,
    *,
    topics: TopicMap | None = None,
    mount: Pose2D | None = None,
    params: ObservationParams = DEFAULT_OBSERVATION,
) -> dict[str, Any]:
    """Per-sector reading statistics of one bag's scan topic (see the module docstring).

    Returns {"bag", "topic", "scans", "scan_messages", "skipped": {reason: messages}, "mount",
    "outside_fov", "sectors": [K dicts], "total": dict}; each sector dict has from_deg, to_deg, beams, valid, valid_ratio, the
    ``READING_CLASSES`` counts and noise_std (m, None with fewer than two differences).
    """
    bag = read_bag(bag_path, topics=topics, mount=mount)
    k_all = params.sectors
    counts = np.zeros((k_all + 1, 1 + len(READING_CLASSES) + 1), dtype=np.int64)  # row K: total
    diffs: list[list[np.ndarray]] = [[] for _ in range(k_all + 1)]
    outside = 0
    groups: dict[tuple, list[LaserScan]] = {}
    for scan in bag.scans:
        key = (
            scan.ranges.size,
            scan.angle_min,
            scan.angle_increment,
            scan.range_min,
            scan.range_max,
        )
        groups.setdefault(key, []).append(scan)
    for (_, _, _, rmin, rmax), scans in groups.items():
        sector = beam_sectors(scans[0], bag.mount, params)
        ranges = np.stack([s.ranges for s in scans])
        masks = classify_readings(ranges, rmin, rmax)
        outside += int((sector < 0).sum()) * len(scans)
        one_hot = np.equal.outer(sector, np.arange(k_all))  # (N, K)
        for c, name in enumerate(("valid", *READING_CLASSES)):
            per_sector = masks[name].sum(axis=0) @ one_hot
            counts[:k_all, c] += per_sector
        counts[:k_all, -1] += len(scans) * one_hot.sum(axis=0)
        both = masks["valid"][1:] & masks["valid"][:-1]
        with np.errstate(invalid="ignore"):  # inf - inf where a beam is invalid; masked below
            d = ranges[1:] - ranges[:-1]
        beam_sector = np.broadcast_to(sector, d.shape)
        for k in range(k_all):
            diffs[k].append(d[both & (beam_sector == k)])
        diffs[k_all].append(d[both & (beam_sector >= 0)])
    counts[k_all] = counts[:k_all].sum(axis=0)

    def row(k: int) -> dict[str, Any]:
        beams = int(counts[k, -1])
        valid = int(counts[k, 0])
        out: dict[str, Any] = {"beams": beams, "valid": valid}
        out["valid_ratio"] = valid / beams if beams else None
        for c, name in enumerate(READING_CLASSES, start=1):
            out[name] = int(counts[k, c])
        out["noise_std"] = difference_noise_std(np.concatenate(diffs[k])) if diffs[k] else None
        return out

    width = math.degrees(params.fov) / k_all
    start = -0.5 * math.degrees(params.fov)
    sectors = [
        {"sector": k, "from_deg": start + k * width, "to_deg": start + (k + 1) * width, **row(k)}
        for k in range(k_all)
    ]
    return {
        "bag": str(bag.path),
        "topic": bag.topics["scan"],
        "scans": len(bag.scans),
        "scan_messages": bag.scan_messages,
        "skipped": skipped_scans(bag.scan_rejects),
        "mount": {"x": bag.mount.x, "y": bag.mount.y, "yaw": bag.mount.yaw},
        "mount_source": bag.mount_source,
        "outside_fov": outside,
        "sectors": sectors,
        "total": row(k_all),
        "notes": list(bag.notes),
    }


def skipped_scans(rejects: list[tuple[int, str]]) -> dict[str, int]:
    """{reason: messages} of a bag's rejected scan messages, by reason."""
    out: dict[str, int] = {}
    for _, reason in rejects:
        out[reason] = out.get(reason, 0) + 1
    return dict(sorted(out.items()))


def describe_skipped(stats: dict[str, Any]) -> str:
    """'3 zero beams, 1 corrupt message' for a bag's stats ('' if nothing was skipped)."""
    return ", ".join(f"{n} {reason}" for reason, n in stats.get("skipped", {}).items())


def compare_scans(
    bag_a: str | Path,
    bag_b: str | Path,
    *,
    topics: TopicMap | None = None,
    mount_a: Pose2D | None = None,
    mount_b: Pose2D | None = None,
    params: ObservationParams = DEFAULT_OBSERVATION,
) -> dict[str, Any]:
    """``scan_statistics`` of two bags: {"a": stats of bag_a, "b": stats of bag_b}."""
    return {
        "a": scan_statistics(bag_a, topics=topics, mount=mount_a, params=params),
        "b": scan_statistics(bag_b, topics=topics, mount=mount_b, params=params),
    }


def format_scan_comparison(result: dict[str, Any]) -> str:
    """A Markdown table, one row per sector plus a total; each cell reads 'a / b'."""
    a, b = result["a"], result["b"]

    def pct(x: float | None) -> str:
        return "-" if x is None else f"{100 * x:.1f}%"

    def mm(x: float | None) -> str:
        return "-" if x is None else f"{1000 * x:.1f}"

    def cells(ra: dict[str, Any], rb: dict[str, Any]) -> list[str]:
        out = [
            f"{ra['beams']} / {rb['beams']}",
            f"{pct(ra['valid_ratio'])} / {pct(rb['valid_ratio'])}",
        ]
        out += [f"{ra[c]} / {rb[c]}" for c in READING_CLASSES]
        out.append(f"{mm(ra['noise_std'])} / {mm(rb['noise_std'])}")
        return out

    header = [
        "sector",
        "deg",
        "beams",
        "valid",
        "NaN",
        "+inf",
        "-inf",
        "0.0",
        "out of range",
        "noise [mm]",
    ]
    lines = [
        f"a: `{a['bag']}` ({a['topic']}, {a['scans']} scans); b: `{b['bag']}` ({b['topic']}, {b['scans']} scans)",
        *(
            f"{name}: {s['scan_messages'] - s['scans']} of {s['scan_messages']} scan messages "
            f"left out ({describe_skipped(s)})"
            for name, s in (("a", a), ("b", b))
            if s.get("skipped")
        ),
        "",
        "| " + " | ".join(header) + " |",
        "|" + "|".join("---" for _ in header) + "|",
    ]
    for sa, sb in zip(a["sectors"], b["sectors"], strict=True):
        span = f"{sa['from_deg']:+.0f}..{sa['to_deg']:+.0f}"
        lines.append("| " + " | ".join([str(sa["sector"]), span, *cells(sa, sb)]) + " |")
    lines.append("| " + " | ".join(["all", "", *cells(a["total"], b["total"])]) + " |")
    return "\n".join(lines) + "\n"
