"""Chen et al. 2000's NDOB: a step disturbance is estimated as the first-order filter of its design,
d(d_hat)/dt = X^-1 M^-1 (d - d_hat), exactly in discrete time with an exactly measured velocity (and within a
stated tolerance with the Levant differentiator's velocity); the estimate's sign and units (M^-1 d_hat, an
acceleration); the sensors each name needs.

The plant is qdd = Psi + M^-1 tau + delta with a constant (matrix) M, a known Psi and torque, and a LUaF step
delta from t = 0 (torque disturbance d = M delta), integrated exactly over each period.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from double_integrator import DT, FakeStepModel

from ftc_mj.methods.observers import BUILTIN, NDOB, LevantNDOB

M2 = np.array([[2.0, 0.4], [0.4, 0.8]])
PSI = np.array([0.3, -0.5])


def make(cls, n_joints: int, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def run(observer, M: np.ndarray, delta: np.ndarray, steps: int, measured: bool = True) -> np.ndarray:
    """LUaF estimates per period, ``(steps, n)``; the observer starts at the true state with d_hat = 0."""
    n = len(M)
    step = FakeStepModel(M, psi_hat=PSI[:n])
    q, v = np.full(n, 0.3), np.full(n, -0.2)
    observer.reset(q, v)
    out = np.empty((steps, n))
    for k in range(steps):
        t = k * DT
        tau = np.sin(2.0 * t + np.arange(n))
        observer.measure(q, v if measured else None)
        observer.update(t, q, step)
        out[k] = observer.luaf_hat
        a = PSI[:n] + np.linalg.solve(M, tau) + delta
        q, v = q + v * DT + 0.5 * a * DT**2, v + a * DT
        observer.advance(tau, step)
    return out


def test_a_step_follows_the_first_order_filter_of_one_joint():
    """One joint of inertia m: d_hat(k) = d (1 - (1 - dt / (X m))^k) exactly, e^(-t / (X m)) within dt."""
    m, X, delta = 2.0, 0.01, 1.5  # time constant X m = 20 ms
    estimate = run(make(NDOB, 1, X=X), np.array([[m]]), np.array([delta]), 200)[:, 0]
    k = np.arange(200)
    np.testing.assert_allclose(estimate, delta * (1.0 - (1.0 - DT / (X * m)) ** k), rtol=0, atol=1e-12)
    continuous = delta * (1.0 - np.exp(-k * DT / (X * m)))
    assert np.abs(estimate - continuous).max() < delta * DT / (X * m)  # the Euler step's error, below 1/20 of d
    assert estimate[-1] == pytest.approx(delta, rel=1e-4)  # converged, with the sign of the disturbance


def test_a_step_follows_the_coupled_filter_of_two_joints():
    """Two coupled joints: the torque estimate's error decays as (I - dt X^-1 M^-1)^k; the LUaF estimate is
    M^-1 d_hat (an acceleration, not the torque)."""
    X, delta = np.array([0.02, 0.05]), np.array([1.0, -2.0])
    estimate = run(make(NDOB, 2, X=X.tolist()), M2, delta, 300)
    d = M2 @ delta
    step = np.eye(2) - DT * np.diag(1.0 / X) @ np.linalg.inv(M2)
    error, expected = d.copy(), np.empty((300, 2))  # d - d_hat, from d_hat(0) = 0
    for k in range(300):
        expected[k] = np.linalg.solve(M2, d - error)
        error = step @ error
    np.testing.assert_allclose(estimate, expected, rtol=0, atol=1e-11)


def test_the_levant_velocity_gives_the_same_filter_within_its_accuracy():
    m, X, delta = 2.0, 0.01, 1.5
    estimate = run(make(LevantNDOB, 1, X=X, L=50.0, order=2), np.array([[m]]), np.array([delta]), 2000,
                   measured=False)[:, 0]
    k = np.arange(2000)
    exact = delta * (1.0 - (1.0 - DT / (X * m)) ** k)
    # The differentiator's velocity error enters the torque estimate as X^-1 times it (measured: the LUaF
    # estimate within 0.011 of the exact filter after 0.5 s).
    assert np.abs(estimate - exact)[500:].max() < 0.05


def test_sensors_and_schema():
    assert BUILTIN["ndob"] is NDOB and BUILTIN["ndob_levant"] is LevantNDOB
    assert NDOB.requires == {"position", "velocity"} and LevantNDOB.requires == {"position"}
    with pytest.raises(ValueError, match="measured velocities"):
        make(NDOB, 1, X=0.1).measure(np.zeros(1), None)
    with pytest.raises(ValidationError):
        NDOB.Config.model_validate({"X": 0.0}, context={"n_joints": 2})
    with pytest.raises(ValidationError):
        NDOB.Config.model_validate({"X": 1.0, "L": 3.0}, context={"n_joints": 2})  # no differentiator here
    with pytest.raises(ValidationError):
        LevantNDOB.Config.model_validate({"X": 1.0}, context={"n_joints": 2})  # L missing
