"""NTSMC with the time-decaying terminal term, eqs. (3.50)-(3.53), on the exact closed loop of closed_loop.py.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from closed_loop import DT, Period, make, reaching, settled, simulate

from ftc_mj.methods.controllers import NTSMC

# Table 3.2's beta2, lambda, alpha; beta1 = 5 (Table 3.2: 1.5) so that the test converges in 3 s; K = 1.
GAINS = dict(beta1=5.0, beta2=0.4, decay=0.7, alpha=0.3, bound=0.5, mu=0.5)


def printed(t, e, e_dot, c=GAINS):
    """(3.50) and A of (3.52) as printed, over two joints: return (terminal term of s, A)."""
    fade, squared, inner = math.exp(-c["decay"] * t), e @ e, e @ e_dot
    alpha, decay = c["alpha"], c["decay"]
    A = (
        -decay * fade * squared**-alpha * e
        - 2 * alpha * fade * squared ** (-alpha - 1) * inner * e
        + fade * squared**-alpha * e_dot
    )
    return fade * squared**-alpha * e, A


@pytest.mark.parametrize(
    "change",
    [
        {"beta1": None},  # missing
        {"decay": None},
        {"alpha": None},
        {"alpha": 1.0},  # 0 < alpha < 1
        {"decay": 0.0},  # lambda > 0
        {"beta2": -0.4},
        {"mu": [0.5, 0.5]},  # wrong length for 3 joints
        {"lambda": 0.7},  # unknown key (the field is ``decay``)
    ],
)
def test_config_errors_raise_validation_error(change):
    gains = {k: v for k, v in {**GAINS, **change}.items() if v is not None}
    with pytest.raises(ValidationError):
        NTSMC.Config.model_validate(gains, context={"n_joints": 3})


@pytest.mark.parametrize("t", [0.0, 0.8])
def test_one_period_by_hand(t):
    """s = e_dot + b1 e + b2 exp(-lambda t) (e^T e)^(-alpha) e; tau = -M (Psi + b1 e_dot + b2 A - xdd_d + u_c
    + (bound + mu) sign(s)), with e^T e over both joints."""
    controller = make(NTSMC, 2, **GAINS)  # compensation: estimate, as in (3.52)
    period = Period("estimate", t=t, qd_hat=(-0.5, 0.7))  # e = [0.2, -0.1], e_dot = [-0.7, 0.4]
    e, e_dot, b1, b2 = period.e, period.e_dot, GAINS["beta1"], GAINS["beta2"]
    terminal, A = printed(t, e, e_dot)
    s = e_dot + b1 * e + b2 * terminal

    tau = period.compute(controller)
    np.testing.assert_allclose(controller.sliding, s, rtol=1e-13)
    np.testing.assert_allclose(tau, period.expected(b1 * e_dot + b2 * A, 1.0, s), rtol=1e-13)


def test_zero_error_gives_finite_torque_and_no_terminal_terms():
    """At e = 0 both the terminal term (|e|^(1 - 2 alpha)) and A (|e|^(-2 alpha) e_dot) are set to 0."""
    controller = make(NTSMC, 2, **GAINS)
    period = Period("estimate", q=(0.1, 0.0), qd_hat=(-0.5, 0.7))  # q = q_ref
    tau = period.compute(controller)
    assert np.all(np.isfinite(tau))
    np.testing.assert_array_equal(controller.sliding, period.e_dot)
    np.testing.assert_allclose(tau, period.expected(GAINS["beta1"] * period.e_dot, 1.0, period.e_dot), rtol=1e-14)


def test_terminal_term_couples_the_joints_through_e_transpose_e():
    """Joint 1's sliding variable changes with joint 2's error: the weight is (e1^2 + e2^2)^(-alpha)."""
    controller = make(NTSMC, 2, **GAINS)
    e_dot, b1, b2 = np.array([0.3, 0.0]), GAINS["beta1"], GAINS["beta2"]
    terminal = {}
    for e2 in (0.0, 0.2):
        e = np.array([0.1, e2])
        controller.surface(0.0, e, e_dot)
        terminal[e2] = (controller.sliding[0] - e_dot[0] - b1 * e[0]) / b2
    assert terminal[0.0] == pytest.approx(0.1 ** (1 - 2 * GAINS["alpha"]), rel=1e-13)  # joint 1 alone
    assert terminal[0.2] / terminal[0.0] == pytest.approx((0.05 / 0.01) ** -GAINS["alpha"], rel=1e-13)


@pytest.mark.parametrize("t", [0.5, 2.0, 5.0])
def test_terminal_terms_fade_with_exp_minus_lambda_t(t):
    controller = make(NTSMC, 2, **GAINS)
    e, e_dot, b1 = np.array([0.2, -0.1]), np.array([-0.7, 0.4]), GAINS["beta1"]
    terms_0 = controller.surface(0.0, e, e_dot) - b1 * e_dot
    surface_0 = controller.sliding - e_dot - b1 * e
    terms_t = controller.surface(t, e, e_dot) - b1 * e_dot
    surface_t = controller.sliding - e_dot - b1 * e
    fade = math.exp(-GAINS["decay"] * t)
    np.testing.assert_allclose(surface_t, fade * surface_0, rtol=1e-13)
    np.testing.assert_allclose(terms_t, fade * terms_0, rtol=1e-13)


def test_reaching_law_and_tracking():
    """Two coupled joints; the reaching law holds only if b2 A is the exact time derivative of the terminal term
    (measured deviation per period without A's -lambda term: 1.3e-4; without its e^T e_dot term: 3.6e-4)."""
    run = simulate(make(NTSMC, 2, **GAINS), T=3.0, e0=[0.2, -0.1], ed0=[-0.5, 0.5])
    measured = reaching(run, 1.0)
    assert measured["deviation"] < 1.5e-5  # measured 6.0e-6
    # |s_j(0)| / K: measured 0.698 s and 0.098 s.
    np.testing.assert_allclose(measured["t_reach"], np.abs(run["s"][0]), atol=3 * DT)
    # Measured max |s| / (K dt) after reaching: 3.19. Near e = 0, A ~ |e|^(-2 alpha) e_dot varies fast inside a
    # period and the discrete s leaves the one-period band by a few K dt until exp(-lambda t) fades it.
    assert measured["band_ratio"] < 8.0
    rms = settled(run, 2.0)
    assert rms["e"] < 5e-6  # measured RMS from 2 s: 1.7e-6 rad
    assert rms["e_dot"] < 1.5e-3  # measured 5.4e-4 rad/s
