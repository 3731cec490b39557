"""Odometry and gyro parameters of a randomisation profile, from a robot's bags.

Needs a *reference*: the bag's fused odometry (``odometry`` role; e.g. the robot's own
lidar/map localisation, or motion capture). Without it nothing here is estimated and the
profile keeps the base's values, saying why.

* **Wheel geometry** (wheel odometry + reference): over each wheel-odometry interval, the
  forward travel ``ds`` and yaw change ``dth`` of both, in the body frame at the interval's
  start. The wheel odometry believes radii ``r * s_l``, ``r * s_r`` and track ``T * s_t``, so
  ``ds_w = (s_l d_l + s_r d_r) / 2`` and ``dth_w = (s_r d_r - s_l d_l) / (T s_t)`` with the
  true wheel travels ``d_l, d_r = ds -+ T dth / 2`` from the reference; ``scipy.optimize.
  least_squares`` fits (s_l, s_r, s_t), each residual scaled by its robust spread. The
  simulator draws each scale as ``1 + N(0, std)``; the profile's ``radius_error_std`` is the
  RMS of this robot's two radius errors and ``track_error_std`` its track error (the size of
  the error; its sign is not a profile parameter). Mean wheel slip is indistinguishable from
  a radius error and ends up in it.
* **Drift** (``walk_std``, ``yaw_walk_std``): the robust std of the fit's position residuals
  (both body axes) and yaw residuals, divided by sqrt(interval).
* **Gyro** (IMU + reference): ``e = gyro - reference yaw rate`` (the reference's yaw change over
  each IMU interval); ``bias_std`` = |mean e|, ``gyro_std`` = robust std of ``diff(e)`` / sqrt 2,
  and ``bias_walk_std`` from the growth of ``var(e[i+L] - e[i])`` with the lag (``np.polyfit``;
  kept from the base when the wander over the bag is below the white noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import median_abs_deviation

from d3dwa_bullet.geometry import wrap_angles
from d3dwa_bullet.robot import TRACK
from transfer.bag_reader import BagData
from transfer.calibrate_scans import Estimate
from transfer.time_series import OdometrySeries

#: Motion the geometry fit needs: metres driven and radians turned, over all bags.
MIN_TRAVEL, MIN_TURN = 1.0, 1.0
#: Samples the fits need (wheel intervals, IMU samples).
MIN_SAMPLES = 50
#: Largest lag of the bias-wander fit, as a fraction of the IMU samples.
MAX_LAG_FRACTION = 0.25

ODOMETRY_PARAMS = (
    "odometry.radius_error_std",
    "odometry.track_error_std",
    "odometry.walk_std",
    "odometry.yaw_walk_std",
)
IMU_PARAMS = ("imu.gyro_std", "imu.bias_std", "imu.bias_walk_std")


@dataclass
class MotionCalibration:
    estimates: dict[str, Estimate] = field(default_factory=dict)
    kept: dict[str, str] = field(default_factory=dict)
    """Parameter -> why it was not estimated."""
    fit: dict[str, float] = field(default_factory=dict)
    """The fitted scales and bias, for reports: scale_left, scale_right, scale_track, bias."""


def _robust_std(x: np.ndarray) -> float:
    return float(median_abs_deviation(x, scale="normal"))


def _reference(bag: BagData) -> OdometrySeries | None:
    """The fused odometry, if the bag has one besides the wheel odometry."""
    return bag.odometry if bag.topics["odometry"] is not None else None


def _increments(
    t_ns: np.ndarray, pose: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per interval: dt (s), body-frame (dx, dy) at the start (m), dyaw (rad)."""
    d = np.diff(pose[:, :2], axis=0)
    yaw = pose[:-1, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    dx, dy = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    return np.diff(t_ns) / 1e9, dx, dy, wrap_angles(np.diff(pose[:, 2]))


def _wheel_intervals(bags: list[BagData]) -> np.ndarray | None:
    """(M, 6) rows [dt, ds_ref, dth_ref, dx_w, dy_w, dth_w] of all bags' intervals, or None."""
    rows = []
    for bag in bags:
        ref, wheel = _reference(bag), bag.wheel_odometry
        if ref is None or wheel is None or len(wheel) < 2:
            continue
        t = wheel.t_ns
        rpose, _, where = ref.at(t)
        inside = (where[1:] == 0) & (where[:-1] == 0)
        wpose = np.column_stack((wheel.x, wheel.y, wheel.yaw))
        dt, rdx, _, rdth = _increments(t, rpose)
        _, wdx, wdy, wdth = _increments(t, wpose)
        ok = inside & (dt > 0)
        rows.append(np.column_stack((dt, rdx, rdth, wdx, wdy, wdth))[ok])
    return np.concatenate(rows) if rows else None


def _geometry(rows: np.ndarray, out: MotionCalibration) -> None:
    dt, ds, dth, wdx, wdy, wdth = rows.T
    d_l, d_r = ds - 0.5 * TRACK * dth, ds + 0.5 * TRACK * dth

    def model(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s_l, s_r, s_t = p
        return 0.5 * (s_l * d_l + s_r * d_r), (s_r * d_r - s_l * d_l) / (TRACK * s_t)

    scale = np.array([1.0, 1.0])
    fit = np.ones(3)
    for _ in range(2):  # equal weights first, then each residual by its robust spread
        res = least_squares(
            lambda p, w=scale: np.concatenate(
                [(m - y) / s for m, y, s in zip(model(p), (wdx, wdth), w, strict=True)]
            ),
            fit,
            method="lm",
        )
        fit = res.x
        ds_res, dth_res = (m - y for m, y in zip(model(fit), (wdx, wdth), strict=True))
        scale = np.array([max(_robust_std(ds_res), 1e-9), max(_robust_std(dth_res), 1e-12)])
    s_l, s_r, s_t = (float(v) for v in fit)
    n = rows.shape[0]
    e_l, e_r, e_t = s_l - 1.0, s_r - 1.0, s_t - 1.0
    how = (
        f"wheel vs reference odometry over {n} intervals ({np.abs(ds).sum():.1f} m, "
        f"{np.abs(dth).sum():.1f} rad): fitted radius scales {s_l:.4f} / {s_r:.4f}, "
        f"track scale {s_t:.4f}"
    )
    out.estimates["odometry.radius_error_std"] = Estimate(
        round(math.sqrt(0.5 * (e_l**2 + e_r**2)), 5), "RMS radius error; " + how
    )
    out.estimates["odometry.track_error_std"] = Estimate(
        round(abs(e_t), 5), "|track error|; " + how
    )
    # Residual position in the body frame: the fitted travel along x, nothing sideways.
    ds_fit, dth_fit = model(fit)
    sq = np.sqrt(dt)
    pos = np.concatenate(((wdx - ds_fit) / sq, (wdy - 0.5 * ds_fit * dth_fit) / sq))
    out.estimates["odometry.walk_std"] = Estimate(
        round(_robust_std(pos), 6),
        f"robust std of the fit's position residuals / sqrt(dt) over {n} intervals",
    )
    out.estimates["odometry.yaw_walk_std"] = Estimate(
        round(_robust_std((wdth - dth_fit) / sq), 6),
        f"robust std of the fit's yaw residuals / sqrt(dt) over {n} intervals",
    )
    out.fit.update(scale_left=s_l, scale_right=s_r, scale_track=s_t)


def _gyro_errors(bags: list[BagData]) -> tuple[np.ndarray, float] | None:
    """Gyro minus reference yaw rate per IMU interval (rad/s), and the mean interval (s)."""
    errs, dts = [], []
    for bag in bags:
        ref, imu = _reference(bag), bag.imu
        if ref is None or imu is None or len(imu) < 2:
            continue
        rpose, _, where = ref.at(imu.t_ns)
        dt = np.diff(imu.t_ns) / 1e9
        ok = (where[1:] == 0) & (where[:-1] == 0) & (dt > 0)
        rate = wrap_angles(np.diff(rpose[:, 2])) / np.where(dt > 0, dt, 1.0)
        errs.append((imu.w_z[1:] - rate)[ok])
        dts.append(dt[ok])
    if not errs:
        return None
    e = np.concatenate(errs)
    return e, float(np.mean(np.concatenate(dts))) if e.size else 0.0


def _gyro(e: np.ndarray, dt: float, out: MotionCalibration) -> None:
    n = e.size
    bias = float(np.mean(e))
    white = _robust_std(np.diff(e)) / math.sqrt(2.0)
    out.estimates["imu.bias_std"] = Estimate(
        round(abs(bias), 6), f"|mean gyro - reference yaw rate| over {n} IMU samples"
    )
    out.estimates["imu.gyro_std"] = Estimate(
        round(white, 6),
        f"robust std of successive differences of that error / sqrt 2 ({n} samples)",
    )
    out.fit["bias"] = bias
    lags = np.unique(np.linspace(1, max(2, int(MAX_LAG_FRACTION * n)), 20).astype(int))
    var = np.array([_robust_std(e[lag:] - e[:-lag]) ** 2 for lag in lags])
    slope = float(np.polyfit(lags * dt, var, 1)[0])
    span = n * dt
    if slope <= 0 or slope * span < white**2:
        out.kept["imu.bias_walk_std"] = (
            f"not identifiable: the bias wander over this {span:.0f} s of data is below the "
            f"gyro's white noise"
        )
        return
    out.estimates["imu.bias_walk_std"] = Estimate(
        round(math.sqrt(slope), 7),
        f"growth of var(error[i+L] - error[i]) with the lag L over {n} samples (np.polyfit)",
    )


def calibrate_motion(bags: list[BagData]) -> MotionCalibration:
    """Estimate odometry and gyro parameters where the bags allow (module docstring); every
    parameter not estimated is in ``kept`` with the reason."""
    out = MotionCalibration()
    has_ref = any(_reference(b) is not None for b in bags)
    has_wheel = any(b.wheel_odometry is not None for b in bags)
    has_imu = any(b.imu is not None for b in bags)
    rows = _wheel_intervals(bags)
    if not has_ref:
        why = "no reference (fused) odometry in the bags to compare with"
    elif not has_wheel:
        why = "no wheel odometry in the bags"
    elif rows is None or rows.shape[0] < MIN_SAMPLES:
        why = (
            f"{0 if rows is None else rows.shape[0]} wheel/reference intervals (need {MIN_SAMPLES})"
        )
    else:
        travel, turn = float(np.abs(rows[:, 1]).sum()), float(np.abs(rows[:, 2]).sum())
        why = (
            f"the robot drove {travel:.2f} m and turned {turn:.2f} rad (need {MIN_TRAVEL} m "
            f"and {MIN_TURN} rad)"
            if travel < MIN_TRAVEL or turn < MIN_TURN
            else ""
        )
    if why:
        out.kept.update(dict.fromkeys(ODOMETRY_PARAMS, why))
    else:
        assert rows is not None
        _geometry(rows, out)
    gyro = _gyro_errors(bags) if has_ref and has_imu else None
    if not has_imu:
        out.kept.update(dict.fromkeys(IMU_PARAMS, "no IMU in the bags"))
    elif not has_ref:
        out.kept.update(dict.fromkeys(IMU_PARAMS, "no reference (fused) odometry in the bags"))
    elif gyro is None or gyro[0].size < MIN_SAMPLES:
        n = 0 if gyro is None else gyro[0].size
        out.kept.update(
            dict.fromkeys(IMU_PARAMS, f"{n} IMU samples under the reference (need {MIN_SAMPLES})")
        )
    else:
        _gyro(*gyro, out)
    return out
