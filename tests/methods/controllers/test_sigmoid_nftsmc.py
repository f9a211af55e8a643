"""Chapter 3's NFTSMC on the sigmoid-blended surface (3.18), laws (3.26)-(3.28) and (3.35)-(3.37), on the exact
closed loop of closed_loop.py.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from closed_loop import DT, Period, make, reaching, settled, simulate

from ftc_mj.methods.controllers import SigmoidNFTSMC

# The scenario's (two_link_tosmo_simple.yaml, phi = 0.487) but mu = 0.5, so that K = 1.
GAINS = dict(kappa1=2.0, kappa2=1.5, mu1=1.2, mu2=1.4, alpha=0.6, bound=0.5, mu=0.5)
PHI = 0.75**2.5
POINTS = np.array([-2.0, -0.3, 0.02, PHI, 1.0])  # both signs, near 0, at phi, far out


def sigmoids(e):
    """a(e), b(e) of (3.18) and E1, E2 of the docstring."""
    k1, k2, m1, m2 = (GAINS[key] for key in ("kappa1", "kappa2", "mu1", "mu2"))
    E1, E2 = np.exp(-m1 * (np.abs(e) - PHI)), np.exp(m2 * (np.abs(e) - PHI))
    return 2 * k1 / (1 + E1), 2 * k2 / (1 + E2), E1, E2


def slope(e):
    """d/de [a(e) e + b(e) |e|^alpha sign(e)] as the module's docstring writes it."""
    k1, k2, m1, m2, alpha = (GAINS[key] for key in ("kappa1", "kappa2", "mu1", "mu2", "alpha"))
    a, b, E1, E2 = sigmoids(e)
    m = np.abs(e)
    return (
        a
        + 2 * k1 * m1 * m * E1 / (1 + E1) ** 2
        + b * alpha * m ** (alpha - 1)
        - 2 * k2 * m2 * E2 / (1 + E2) ** 2 * m**alpha
    )


def surface_part(controller, e):
    """The controller's s - e_hat = a(e) e + b(e) |e|^alpha sign(e)."""
    controller.surface(0.0, e, np.zeros_like(e))
    return controller.sliding.copy()


def test_phi_is_where_the_linear_and_terminal_gains_meet():
    controller = make(SigmoidNFTSMC, 2, **{**GAINS, "kappa2": [1.5, 3.0]})
    phi = np.array([0.75, 1.5]) ** 2.5  # (k2 / k1)^(1 / (1 - alpha))
    np.testing.assert_allclose(controller.config.phi(), phi, rtol=1e-14)
    np.testing.assert_allclose(controller.phi, phi, rtol=1e-14)
    np.testing.assert_allclose(2.0 * phi, [1.5, 3.0] * phi**0.6, rtol=1e-14)  # k1 |e| = k2 |e|^alpha


@pytest.mark.parametrize(
    "change",
    [
        {"kappa1": None},  # missing
        {"mu2": None},
        {"alpha": 0.0},
        {"kappa2": 0.0},
        {"kappa1": 1e-3, "kappa2": 1e3, "alpha": 0.99},  # phi = (1e6)^100 overflows
        {"compensation": "gamma2"},
        {"phi": 0.5},  # derived, not a key
    ],
)
def test_config_errors_raise_validation_error(change):
    gains = {k: v for k, v in {**GAINS, **change}.items() if v is not None}
    with pytest.raises(ValidationError):
        SigmoidNFTSMC.Config.model_validate(gains, context={"n_joints": 2})


def test_surface_matches_3_18():
    controller = make(SigmoidNFTSMC, len(POINTS), **GAINS)
    e_hat = np.linspace(-1.0, 1.0, len(POINTS))
    a, b, _, _ = sigmoids(POINTS)
    controller.surface(0.0, POINTS, e_hat)
    expected = e_hat + a * POINTS + b * np.abs(POINTS) ** 0.6 * np.sign(POINTS)
    np.testing.assert_allclose(controller.sliding, expected, rtol=1e-13)


def test_slope_is_the_derivative_of_the_surface_not_the_printed_3_27():
    """The returned term e_hat * slope has slope = d/de of the surface's e-part (central differences of the
    controller's own surface; measured relative difference at most 1.9e-10). (3.27) prints the second term with
    sign(e) in place of e: measured 1.73 off at e = -2, 1.09 at e = 0.02 (equal at e = 1)."""
    controller = make(SigmoidNFTSMC, len(POINTS), **GAINS)
    h = 1e-6
    numerical = (surface_part(controller, POINTS + h) - surface_part(controller, POINTS - h)) / (2 * h)
    returned = controller.surface(0.0, POINTS, np.ones_like(POINTS))  # e_hat = 1: the slope itself
    np.testing.assert_allclose(returned, numerical, rtol=1e-8)
    np.testing.assert_allclose(returned, slope(POINTS), rtol=1e-13)

    k1, m1 = GAINS["kappa1"], GAINS["mu1"]
    _, _, E1, _ = sigmoids(POINTS)
    as_printed = slope(POINTS) + 2 * k1 * m1 * (np.sign(POINTS) - np.abs(POINTS)) * E1 / (1 + E1) ** 2
    assert np.abs(as_printed - numerical).max() > 0.5


def test_zero_error_gives_finite_output():
    """At e = 0 the |e|^(alpha - 1) factor is set to 0: s = e_hat and the slope is a(0)."""
    controller = make(SigmoidNFTSMC, 2, **GAINS)
    e_hat = np.array([0.4, -0.3])
    terms = controller.surface(0.0, np.zeros(2), e_hat)
    a0, _, _, _ = sigmoids(0.0)
    np.testing.assert_array_equal(controller.sliding, e_hat)
    np.testing.assert_allclose(terms, a0 * e_hat, rtol=1e-14)


@pytest.mark.parametrize("compensation", ["injection", "estimate"])
def test_one_period_by_hand(compensation):
    """tau = -M (Psi - xdd_d + e_hat slope + u_c + (bound + mu) sign(s)), (3.26)-(3.28) / (3.35)-(3.37)."""
    controller = make(SigmoidNFTSMC, 2, **{**GAINS, "compensation": compensation})
    period = Period(compensation, qd_hat=(-0.5, 0.7))  # e = [0.2, -0.1], e_hat = [-0.7, 0.4]
    a, b, _, _ = sigmoids(period.e)
    s = period.e_dot + a * period.e + b * np.abs(period.e) ** 0.6 * np.sign(period.e)
    tau = period.compute(controller)
    np.testing.assert_allclose(controller.sliding, s, rtol=1e-13)
    np.testing.assert_allclose(tau, period.expected(period.e_dot * slope(period.e), 1.0, s), rtol=1e-13)


def test_after_convergence_form_drops_only_the_gamma2_term():
    """(3.36) differs from (3.27) by the injection's non-estimate part gamma2 |x1~|^(1/3) sign(x1~) only:
    tau_injection - tau_estimate = -M (injection - luaf_hat)."""
    taus = {}
    for compensation in ("injection", "estimate"):
        period = Period(compensation, hide_unread=False)
        taus[compensation] = period.compute(make(SigmoidNFTSMC, 2, **{**GAINS, "compensation": compensation}))
    observer = period.observer
    np.testing.assert_allclose(
        taus["injection"] - taus["estimate"], -period.M @ (observer.injection - observer.luaf_hat), rtol=1e-13
    )


def test_reaching_law_and_tracking():
    """The reaching law holds only with the exact derivative: with (3.27)'s printed slope the measured deviation
    per period is 4.7e-4."""
    run = simulate(make(SigmoidNFTSMC, **GAINS), T=2.0, e0=0.2, ed0=-0.5)
    measured = reaching(run, 1.0)
    assert measured["deviation"] < 6e-6  # measured 2.1e-6
    assert measured["t_reach"][0] == pytest.approx(abs(run["s"][0, 0]), abs=3 * DT)  # measured 0.516 s
    # Measured max |s| / (K dt) after reaching: 1.20 (the |e|^(alpha - 1) slope near e = 0).
    assert measured["band_ratio"] < 2.5
    rms = settled(run, 1.5)
    assert rms["e"] < 2e-6  # measured RMS from 1.5 s: 7.0e-7 rad (finite-time convergence of the terminal part)
    assert rms["e_dot"] < 1.5e-3  # measured 6.1e-4 rad/s


def test_terminal_slope_term_is_recorded_and_unbounded_near_zero():
    """The signal ``terminal_slope_term`` is e_hat b(e) alpha |e|^(alpha - 1) of this period; for the same
    e_hat it grows as |e|^(alpha - 1) when e -> 0 (1e-11 rad: 1.6e3 x the value at 1e-3 rad), 0 at e = 0."""
    controller = make(SigmoidNFTSMC, 5, **GAINS)
    e_dot = np.full(5, 0.01)
    controller.surface(0.0, POINTS, e_dot)
    _, b, _, _ = sigmoids(POINTS)
    expected = e_dot * b * GAINS["alpha"] * np.abs(POINTS) ** (GAINS["alpha"] - 1)
    np.testing.assert_allclose(controller.signals["terminal_slope_term"], expected, rtol=1e-12)
    near = np.array([1e-3, 1e-7, 1e-11, -1e-11, 0.0])
    controller.surface(0.0, near, e_dot)
    term = controller.terminal_slope_term
    np.testing.assert_allclose(term[2] / term[0], (1e-11 / 1e-3) ** (GAINS["alpha"] - 1), rtol=1e-3)
    assert term[2] > 100.0 and term[3] == term[2] and term[4] == 0.0
