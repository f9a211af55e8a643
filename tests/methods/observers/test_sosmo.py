"""SOSMO (super-twisting observer, eq. (4.37)) with its low-pass-filtered LUaF estimate (4.39).

Plant: one joint, qdd = tau / m + d(t), integrated exactly over each control period (tau held, d integrated in
closed form), observer at dt = 1 ms with the measured position and the applied torque. Slow input
d(t) = 2 sin t + 1 (as in test_tosmo.py); fast input d(t) = sin 10t + 1 for the filter's lag.

The estimate is compared with d through a least-squares fit a sin(wt) + b cos(wt) + c over the converged
window: the fitted sinusoid gives the filter's lag (phase) free of chattering, the residual gives the ripple.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from double_integrator import DT, FAST, SLOW, FakeStepModel, simulate

from ftc_mj.methods.observers import SOSMO, TOSMO

L_BOUND = 10.0  # k2 = 11 > max |d| = 3


def sinusoid_fit(t, y, w):
    """Fit y = a sin(wt) + b cos(wt) + c: return (amplitude, lag [rad], offset, residual)."""
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    (a, b, c), *_ = np.linalg.lstsq(basis, y, rcond=None)
    return math.hypot(a, b), -math.atan2(b, a), c, y - basis @ np.array([a, b, c])


def make(cls, n_joints: int = 1, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


# --------------------------------------------------------------------------------------------------
# configuration and one period by hand


def test_gains_from_L_use_levants_rule():
    observer = make(SOSMO, 2, L=[4.0, 9.0], filter_time_constant=0.01)
    np.testing.assert_allclose(observer.k1, [3.0, 4.5], rtol=1e-12)  # 1.5 L^(1/2)
    np.testing.assert_allclose(observer.k2, [4.4, 9.9], rtol=1e-12)  # 1.1 L


def test_explicit_gains_are_used_as_given():
    observer = make(SOSMO, 2, k1=[1.0, 2.0], k2=3.0, filter_time_constant=0.01)
    np.testing.assert_array_equal(observer.k1, [1.0, 2.0])
    np.testing.assert_array_equal(observer.k2, [3.0, 3.0])


@pytest.mark.parametrize(
    "gains",
    [
        {"filter_time_constant": 0.01},  # neither L nor k1, k2
        {"k1": 1.0, "filter_time_constant": 0.01},  # k2 missing
        {"L": 1.0, "k2": 1.0, "filter_time_constant": 0.01},  # both
        {"L": 1.0},  # the filter time constant is required
        {"L": 1.0, "filter_time_constant": 0.0},
        {"L": -1.0, "filter_time_constant": 0.01},
        {"L": [1.0, 2.0], "filter_time_constant": 0.01},  # wrong length for 3 joints
        {"L": 1.0, "filter_time_constant": 0.01, "gamma": 1.0},  # unknown key
    ],
)
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        SOSMO.Config.model_validate(gains, context={"n_joints": 3})


def test_one_period_by_hand():
    k1, k2, T = np.array([2.0, 3.0, 1.5]), np.array([4.0, 2.5, 3.0]), 0.02
    observer = make(SOSMO, 3, k1=list(k1), k2=list(k2), filter_time_constant=T)
    q_hat, qd_hat, luaf = np.array([0.1, -0.2, 0.3]), np.array([0.5, 0.0, -1.0]), np.array([0.7, -0.4, 1.2])
    observer.reset(q_hat, qd_hat)
    observer.luaf_hat[:] = luaf
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, -0.2], [0.1, -0.2, 0.8]])
    step = FakeStepModel(M, psi_hat=[0.3, -1.1, 2.0])
    q_meas, tau = np.array([0.15, -0.2001, 0.25]), np.array([1.0, -2.0, 0.5])
    e = q_meas - q_hat

    observer.update(0.0, q_meas, step)
    injection = k2 * np.sign(e)  # (4.39): the raw equivalent output injection
    np.testing.assert_array_equal(observer.injection, injection)

    observer.advance(tau, step)
    np.testing.assert_allclose(observer.q_hat, q_hat + DT * (qd_hat + k1 * np.sqrt(np.abs(e)) * np.sign(e)), rtol=1e-13)
    np.testing.assert_allclose(
        observer.qd_hat, qd_hat + DT * (step.psi_hat + np.linalg.solve(M, tau) + injection), rtol=1e-13
    )
    # Exact discretisation of the first-order filter T dl/dt = injection - l.
    np.testing.assert_allclose(
        observer.luaf_hat, luaf + (1.0 - math.exp(-DT / T)) * (injection - luaf), rtol=1e-13
    )


# --------------------------------------------------------------------------------------------------
# convergence on the double integrator


@pytest.fixture(scope="module")
def slow_runs():
    return {T: simulate(make(SOSMO, L=L_BOUND, filter_time_constant=T), SLOW) for T in (0.01, 0.05)}


def test_velocity_converges(slow_runs):
    run = slow_runs[0.05]
    above = np.nonzero(np.abs(run["vel_err"]) > 0.05)[0]
    settle = run["t"][above[-1] + 1]
    after = run["t"] >= 2.0
    # Measured: settles to 0.05 rad/s at 0.113 s from the 1 rad/s initial error; after 2 s max |error| 0.0228,
    # RMS 0.0092 rad/s (discrete chattering, k2 dt = 0.011 per period).
    assert settle < 0.4
    assert np.abs(run["vel_err"][after]).max() < 0.05
    assert rms(run["vel_err"][after]) < 0.025


def test_filtered_luaf_follows_the_input(slow_runs):
    run = slow_runs[0.05]
    after = run["t"] >= 2.0
    amp, lag, offset, _ = sinusoid_fit(run["t"][after], run["luaf"][after], SLOW.w)
    # Measured: RMS error 0.19, fitted amplitude 1.998 (true 2), offset 1.000 (true 1), lag 0.0520 rad
    # against the filter's atan(w T) = 0.0500.
    assert rms(run["luaf"][after] - run["d"][after]) < 0.4
    assert amp == pytest.approx(2.0, abs=0.04)
    assert offset == pytest.approx(1.0, abs=0.03)
    assert lag == pytest.approx(math.atan(SLOW.w * 0.05), abs=0.01)


def test_longer_filter_means_more_lag_and_less_ripple():
    w = FAST.w
    result = {}
    for T in (0.01, 0.05):
        run = simulate(make(SOSMO, L=L_BOUND, filter_time_constant=T), FAST, T=4.0)
        after = run["t"] >= 2.0
        amp, lag, offset, residual = sinusoid_fit(run["t"][after], run["luaf"][after], w)
        # Error of the estimate's sinusoidal component (the lag error, free of chattering).
        lag_error = abs(amp * np.exp(-1j * lag) - FAST.amp)
        result[T] = (lag, lag_error, rms(residual))
        # Measured lag 0.118 rad (T = 10 ms) and 0.483 rad (T = 50 ms) against atan(w T) = 0.0997, 0.464:
        # the filter plus about 2 ms of the observer's own delay.
        assert lag == pytest.approx(math.atan(w * T), abs=0.05)
    (lag_short, err_short, ripple_short), (lag_long, err_long, ripple_long) = result[0.01], result[0.05]
    # Measured: lag error 0.118 vs 0.464; ripple (RMS of the residual) 0.874 vs 0.177.
    assert lag_long > 3.0 * lag_short
    assert err_long > 2.5 * err_short
    assert ripple_long < ripple_short / 3.0


def test_sosmo_luaf_error_is_larger_than_tosmo(slow_runs):
    """The dissertation's claim (Ch. 5): the TOSMO's integral estimate (5.13) beats the filtered SOSMO."""
    tosmo = simulate(make(TOSMO, D=L_BOUND), SLOW)
    after = tosmo["t"] >= 2.0
    tosmo_rms = rms(tosmo["luaf"][after] - tosmo["d"][after])
    # Measured RMS LUaF error after 2 s: TOSMO 0.0126; SOSMO 0.88 (T = 10 ms), 0.19 (T = 50 ms).
    assert tosmo_rms < 0.03
    for run in slow_runs.values():
        assert rms(run["luaf"][after] - run["d"][after]) > 5.0 * tosmo_rms
