"""Third-order linear ESO with bandwidth parameterisation (the linear comparator of Chapter 2, Fig. 2.3) on
double_integrator.py's exact plant (qdd = tau / m + d(t), d(t) = 2 sin t + 1).

The error dynamics are linear with all poles at -omega: from x2~(0) = a and x3~(0) = d(0) - z_hat(0) = c, the
LUaF error is x3~(t) = e^(-omega t) (c (1 + omega t + (omega t)^2 / 2) - a omega^3 t^2 / 2) (d held constant).

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from double_integrator import DT, SLOW, FakeStepModel, simulate

from ftc_mj.methods.observers import ESO


def make(n_joints=1, bandwidth=20.0) -> ESO:
    return ESO(ESO.Config.model_validate({"bandwidth": bandwidth}, context={"n_joints": n_joints}), n_joints, DT)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture(scope="module")
def runs():
    """Velocity estimate starting 1 rad/s below the truth (a = 1), z_hat = 0 against d(0) = 1 (c = 1)."""
    return {w: simulate(make(bandwidth=w), SLOW, T=2.0, qd_error=-1.0) for w in (20.0, 40.0)}


def test_gains_place_all_poles_at_minus_bandwidth():
    observer = make(2, bandwidth=[10.0, 20.0])
    np.testing.assert_allclose(observer.l1, [30.0, 60.0], rtol=1e-15)
    np.testing.assert_allclose(observer.l2, [300.0, 1200.0], rtol=1e-15)
    np.testing.assert_allclose(observer.l3, [1000.0, 8000.0], rtol=1e-15)
    # s^3 + l1 s^2 + l2 s + l3 = (s + w)^3
    np.testing.assert_allclose(np.roots([1.0, 60.0, 1200.0, 8000.0]), -20.0, atol=0.01)


@pytest.mark.parametrize("gains", [{}, {"bandwidth": 0.0}, {"bandwidth": [10.0]}, {"bandwidth": 10, "L": 1}])
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        ESO.Config.model_validate(gains, context={"n_joints": 2})


def test_two_periods_by_hand():
    """x1~ = q - q_hat; injection = z_hat + 3 omega^2 x1~; then a forward-Euler step of the three equations."""
    w = np.array([10.0, 20.0])
    observer = make(2, bandwidth=list(w))
    step = FakeStepModel([[2.0, 0.3], [0.3, 0.5]], psi_hat=[0.3, -1.1])
    x = [np.array([0.1, -0.2]), np.array([0.5, -1.0]), np.zeros(2)]  # q_hat, qd_hat, z_hat
    observer.reset(x[0], x[1])
    for q_meas, tau in [([0.15, -0.2001], [1.0, -2.0]), ([0.149, -0.19], [0.5, 0.5])]:
        error = np.array(q_meas) - x[0]
        observer.update(0.0, np.array(q_meas), step)
        injection = x[2] + 3 * w**2 * error
        np.testing.assert_allclose(observer.injection, injection, rtol=1e-13)
        observer.advance(np.array(tau), step)
        x = [
            x[0] + DT * (x[1] + 3 * w * error),
            x[1] + DT * (step.psi_hat + np.linalg.solve(step.M, tau) + injection),
            x[2] + DT * w**3 * error,
        ]
        for value, expected in zip((observer.q_hat, observer.qd_hat, observer.luaf_hat), x):
            np.testing.assert_allclose(value, expected, rtol=1e-13)


def test_estimate_converges_and_its_error_shrinks_with_bandwidth(runs):
    after = runs[20.0]["t"] >= 1.0
    error = {w: rms(run["luaf_err"][after]) for w, run in runs.items()}
    # Measured RMS LUaF error after 1 s: 0.096 (omega 20), 0.045 (omega 40): the lag 3 d'/omega of a ramp-like
    # input, so halved by doubling omega (ratio 2.13).
    assert error[20.0] < 0.25
    assert error[40.0] < 0.12
    assert error[20.0] > 1.6 * error[40.0]
    # Measured max |velocity error| after 1 s: 8.1e-3 (20), 2.6e-3 (40) rad/s.
    assert np.abs(runs[20.0]["vel_err"][after]).max() < 0.02
    assert np.abs(runs[40.0]["vel_err"][after]).max() < 0.008


def test_estimate_overshoots_by_the_peaking_of_the_linear_error_dynamics(runs):
    """z_hat starts 1 below d and passes above it by about 2 omega e^-2: the peaking Chapter 2 holds against
    the ESO, growing with the bandwidth."""
    for w, run in runs.items():
        t, overshoot = run["t"], -run["luaf_err"]  # z_hat - d
        assert overshoot[0] == pytest.approx(-1.0)
        tt = np.linspace(0.0, 0.5, 50001)
        predicted = -np.exp(-w * tt) * (1 + w * tt + (w * tt) ** 2 / 2 - w**3 * tt**2 / 2)
        # Measured overshoot 4.62 at 0.103 s (omega 20; predicted 4.75 at 0.105 s) and 10.29 at 0.051 s
        # (omega 40; predicted 10.16 at 0.051 s); d's slope and the 1 ms step account for the difference.
        assert overshoot.max() == pytest.approx(predicted.max(), rel=0.08)
        assert t[overshoot.argmax()] == pytest.approx(tt[predicted.argmax()], abs=0.01)
    # Doubling omega doubles the peak: measured ratio 2.23.
    assert -runs[40.0]["luaf_err"].min() > 1.7 * -runs[20.0]["luaf_err"].min()


def test_batched_state_matches_row_by_row():
    rng = np.random.default_rng(3)
    batch, n, steps = 3, 2, 50
    M = np.array([[2.0, 0.3], [0.3, 0.5]])
    q, tau = rng.normal(size=(2, steps, batch, n))
    start = rng.normal(size=(2, batch, n))

    def run(observer, rows):
        observer.reset(start[0][rows], start[1][rows])
        for k in range(steps):
            observer.update(k * DT, q[k][rows], FakeStepModel(M))
            observer.advance(tau[k][rows], FakeStepModel(M))
        return np.stack([observer.q_hat, observer.qd_hat, observer.luaf_hat])

    config = ESO.Config.model_validate({"bandwidth": [10.0, 30.0]}, context={"n_joints": n})
    batched = run(ESO(config, n, DT, members=batch), slice(None))
    for b in range(batch):
        np.testing.assert_allclose(batched[:, b], run(ESO(config, n, DT), b), rtol=1e-12)
