"""The observers built on a measured velocity (the DO of (2.6), the NDOB, the momentum observer): measure
takes both readings, refuses to run without velocities with its own message, reset leaves a zero residual,
and the injection is the LUaF estimate."""

from __future__ import annotations

import numpy as np
import pytest

from double_integrator import DT, FakeStepModel

from ftc_mj.methods.observers import NDOB, DisturbanceObserver, MomentumObserver

Q, QD = np.array([0.1, -0.2]), np.array([1.5, -0.5])


def make(cls, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": 2}), 2, DT)


@pytest.mark.parametrize(("cls", "gains", "message"), [
    (DisturbanceObserver, {"k1": 8.0, "k2": 18.0, "p1": 10.0, "p2": 10.0},
     r"the DO of \(2.6\) needs measured velocities"),
    (NDOB, {"X": 0.01}, r"ndob needs measured velocities \(ndob_levant differentiates the encoders\)"),
    (MomentumObserver, {"K": 50.0},
     r"momentum needs measured velocities \(momentum_levant differentiates the encoders\)"),
])
def test_measure_takes_both_readings_and_needs_velocities(cls, gains, message):
    observer = make(cls, **gains)
    observer.reset(np.zeros(2), np.zeros(2))
    observer.measure(Q, QD)
    np.testing.assert_array_equal(observer.q_hat, Q)
    np.testing.assert_array_equal(observer.qd_hat, QD)
    with pytest.raises(ValueError, match=f"^{message}$"):
        observer.measure(Q, None)


def test_the_ndob_injection_is_its_estimate():
    """d_hat = z + X^-1 qd, the LUaF estimate M^-1 d_hat, and the injection that estimate."""
    observer = make(NDOB, X=[0.01, 0.02])
    observer.reset(np.zeros(2), np.zeros(2))  # z = 0
    observer.measure(Q, QD)
    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    observer.update(0.0, Q, FakeStepModel(M))
    expected = np.linalg.solve(M, QD / [0.01, 0.02])
    np.testing.assert_allclose(observer.luaf_hat, expected, rtol=1e-14)
    np.testing.assert_array_equal(observer.injection, observer.luaf_hat)


def test_momentum_reset_leaves_a_zero_residual():
    observer = make(MomentumObserver, K=50.0)
    observer.residual[:] = 7.0
    observer.reset(Q, QD)
    np.testing.assert_array_equal(observer.residual, 0.0)
