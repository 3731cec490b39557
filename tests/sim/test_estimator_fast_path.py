"""The EKF's fast path gives the very numbers of filterpy's own predict/update and of an
eigendecomposition every step: it only skips work whose result it can prove."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st

from d3dwa_bullet.sim import estimator as est
from d3dwa_bullet.sim.estimator import PoseEstimator


def drive(filter_: PoseEstimator, seed: int) -> np.ndarray:
    """A random run of readings (with pose fixes and a long gap); every state and P, stacked."""
    rng = np.random.default_rng(seed)
    out, t = [], 0.0
    for k in range(400):
        t += 0.1 if k != 200 else 3.0
        filter_.update_odometry(*rng.normal([0.2, 0.0], [0.1, 0.5]))
        filter_.update_gyro(rng.normal(0.0, 0.5))
        filter_.predict(t)
        if k % 25 == 0:
            filter_.update_pose_fix(*rng.normal([k * 0.01, 0.0, 3.1], [0.05, 0.05, 0.2]))
        out.append(np.concatenate([filter_.state, filter_.covariance.ravel()]))
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fast_path_is_bit_identical_to_filterpy_and_eigh(monkeypatch, seed):
    fast = drive(PoseEstimator(), seed)
    monkeypatch.setattr(est._UnicycleEKF, "predict", ExtendedKalmanFilter.predict)
    monkeypatch.setattr(est._UnicycleEKF, "update", ExtendedKalmanFilter.update)
    monkeypatch.setattr(est, "_eigenvalues_inside", lambda P, low, high: False)
    reference = drive(PoseEstimator(), seed)
    assert fast.tobytes() == reference.tobytes()


def symmetric(values: list[float], n: int) -> np.ndarray:
    a = np.array(values[: n * n]).reshape(n, n)
    return 0.5 * (a + a.T)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=25, max_size=25), st.floats(-12, 2))
def test_a_proof_inside_is_never_wrong(values, log_shift):
    P = symmetric(values, 5) @ symmetric(values, 5).T + 10.0**log_shift * np.eye(5)
    P = 0.5 * (P + P.T)
    low, high = 1e-12, 1e6
    if est._eigenvalues_inside(P, low, high):
        eig = np.linalg.eigvalsh(P)
        assert eig.min() >= low and eig.max() <= high


def test_the_proof_holds_for_a_typical_covariance_and_fails_outside():
    P = np.diag([1e-4, 1e-4, 1e-4, 1e-2, 1e-2])
    P[0, 2] = P[2, 0] = 5e-5  # the position-heading correlation a turn builds
    assert est._eigenvalues_inside(P, 1e-12, 1e6)
    assert not est._eigenvalues_inside(np.diag([1e-13, 1, 1, 1, 1.0]), 1e-12, 1e6)
    assert not est._eigenvalues_inside(np.diag([1.0, 1, 1, 1, 2e6]), 1e-12, 1e6)
    singular = np.ones((5, 5))  # eigenvalues 0 (four times) and 5
    assert not est._eigenvalues_inside(singular, 1e-12, 1e6)
