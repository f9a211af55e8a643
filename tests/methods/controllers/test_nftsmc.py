"""Observer-based NFTSMC, eqs. (5.14)-(5.27), and the A-NFTSMC, eqs. (2.32)-(2.36), (2.43), on the exact
closed loop of closed_loop.py: one joint, qdd = tau / m + d(t), d(t) = 2 sin t + 1, with a fake observer giving
exact estimates, so that with ``compensation: injection`` eq. (5.32) holds with delta = 0 and the sliding
variable obeys ds/dt = -(bound + mu) sign(s): per period s_{k+1} - s_k = -(bound + mu) dt sign(s_k), up to
O(dt^2) from d and the reference varying inside the period.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

import closed_loop
from closed_loop import DT, FakeObserver, Period, fake_step, reaching, simulate, total_variation

from ftc_mj.methods.controllers import NFTSMC, AdaptiveNFTSMC

GAINS = dict(beta1=15.0, beta2=10.0, beta3=10.0, beta4=5.0, gamma1=0.5, bound=0.5, mu=0.5)  # the scenario's


def make(n_joints: int = 1, **overrides) -> NFTSMC:
    return closed_loop.make(NFTSMC, n_joints, **{**GAINS, **overrides})


# --------------------------------------------------------------------------------------------------
# configuration


@pytest.mark.parametrize("gamma1", [0.2, 0.5, 0.8])
def test_gamma2_defaults_to_2_gamma1_over_1_plus_gamma1(gamma1):
    config = NFTSMC.Config.model_validate({**GAINS, "gamma1": gamma1}, context={"n_joints": 3})
    assert config.gamma2 == pytest.approx(2 * gamma1 / (1 + gamma1), rel=1e-15)


def test_explicit_gamma2_is_kept():
    assert NFTSMC.Config.model_validate({**GAINS, "gamma2": 0.3}).gamma2 == 0.3


def test_switching_gain_is_bound_plus_mu():
    controller = make(3, bound=[0.5, 0.0, 2.0], mu=0.25)
    np.testing.assert_array_equal(controller.switching_gain(), [0.75, 0.25, 2.25])


@pytest.mark.parametrize(
    "change",
    [
        {"gamma1": 1.0},  # 0 < gamma1 < 1
        {"gamma1": 0.0},
        {"gamma2": 1.2},
        {"beta1": 0.0},  # betas positive
        {"mu": 0.0},  # mu positive
        {"bound": -0.1},  # bound non-negative
        {"compensation": "observer"},  # not one of injection / estimate / none
        {"beta3": [1.0, 2.0]},  # wrong length for 3 joints
        {"k": 1.0},  # unknown key
    ],
)
def test_config_errors_raise_validation_error(change):
    with pytest.raises(ValidationError):
        NFTSMC.Config.model_validate({**GAINS, **change}, context={"n_joints": 3})


@pytest.mark.parametrize("required", ["beta1", "beta2", "gamma1", "bound", "mu"])
def test_missing_gain_raises_validation_error(required):
    gains = dict(GAINS)
    del gains[required]
    with pytest.raises(ValidationError):
        NFTSMC.Config.model_validate(gains, context={"n_joints": 3})


def test_chapter_4_surface_has_no_linear_and_cubic_terms():
    """beta3, beta4 default to 0: the surface (4.15) with kappa1 |e|^alpha1 + kappa2 |e_hat|^alpha2 only."""
    gains = {k: v for k, v in GAINS.items() if k not in ("beta3", "beta4")}
    config = NFTSMC.Config.model_validate(gains, context={"n_joints": 3})
    np.testing.assert_array_equal(config.beta3, np.zeros(3))
    np.testing.assert_array_equal(config.beta4, np.zeros(3))


# --------------------------------------------------------------------------------------------------
# two periods by hand


# Two joints' surface gains and two periods' inputs (the first on Period's default reference).
SURFACE = dict(beta1=[15.0, 3.0], beta2=[10.0, 2.0], beta3=[10.0, 1.0], beta4=[5.0, 0.5], gamma1=0.6)
PERIODS = [
    dict(q=(0.3, -0.1), qd_hat=(0.5, 0.2)),
    dict(q=(0.31, -0.09), qd_hat=(0.45, -0.1), q_ref=(0.11, 0.001), qd_ref=(0.25, 0.35), qdd_ref=(-0.5, 0.9)),
]


def rate_by_hand(period: Period) -> np.ndarray:
    """A of (2.22)/(5.15) with SURFACE at the period's e and e_hat, (5.3), (5.14); gamma2 = 2 gamma1 / (1 + gamma1):
    the integrand of the surface and its term in u_eq."""
    b1, b2, b3, b4 = (np.asarray(SURFACE[k]) for k in ("beta1", "beta2", "beta3", "beta4"))
    e, e_hat, g1, g2 = period.e, period.e_dot, 0.6, 2 * 0.6 / 1.6
    return b1 * np.abs(e) ** g1 * np.sign(e) + b2 * np.abs(e_hat) ** g2 * np.sign(e_hat) + b3 * e + b4 * e**3


@pytest.mark.parametrize("compensation", ["injection", "estimate", "none"])
def test_two_periods_by_hand(compensation):
    """tau = -M (u_eq + u_c + u_sw), u_eq = Psi(x_hat) + A - xdd_d, s = e_hat + integral of A (5.15).
    The observer attribute the option does not read is NaN."""
    controller = make(2, **SURFACE, bound=[0.5, 1.0], mu=0.25, compensation=compensation)
    integral = np.zeros(2)
    for inputs in PERIODS:
        period = Period(compensation, **inputs)
        A = rate_by_hand(period)
        s = period.e_dot + integral  # the integral up to the previous period
        tau = period.compute(controller)
        np.testing.assert_allclose(controller.sliding, s, rtol=1e-13)
        np.testing.assert_allclose(tau, period.expected(A, np.array([0.75, 1.25]), s), rtol=1e-13)
        assert tau is controller.tau
        integral = integral + DT * A


def test_reset_restarts_the_surface_integral():
    fresh, used = make(), make()
    simulate(used, T=0.05)
    used.reset()
    a, b = simulate(fresh, T=0.05), simulate(used, T=0.05)
    np.testing.assert_array_equal(a["tau"], b["tau"])
    np.testing.assert_array_equal(a["s"], b["s"])


def test_estimate_compensation_reads_luaf_hat_only():
    """With ``estimate`` the injection is never read (NaN there changes nothing); with ``injection`` the
    LUaF estimate is never read."""
    reference_run = simulate(make(compensation="injection"), T=0.5)
    estimate_run = simulate(make(compensation="estimate"), T=0.5, injection=np.nan)
    injection_run = simulate(make(compensation="injection"), T=0.5, luaf_hat=np.nan)
    np.testing.assert_array_equal(estimate_run["tau"], reference_run["tau"])
    np.testing.assert_array_equal(injection_run["tau"], reference_run["tau"])
    none_run = simulate(make(compensation="none"), T=0.5, injection=np.nan, luaf_hat=np.nan)
    assert np.all(np.isfinite(none_run["tau"]))


# --------------------------------------------------------------------------------------------------
# the reaching law and tracking with exact compensation


@pytest.mark.parametrize("bound, mu", [(0.5, 0.5), (0.0, 2.0)])
def test_sliding_variable_obeys_the_reaching_law(bound, mu):
    K = bound + mu
    run = simulate(make(bound=bound, mu=mu), T=2.5, ed0=1.0)
    s, t = run["s"][:, 0], run["t"]
    assert s[0] == pytest.approx(1.0)  # s(0) = e_hat(0), the integral starts at 0
    measured = reaching(run, K)
    # Per period s decreases by exactly K dt towards 0. Measured deviation 1.25e-6 (d and the reference
    # vary inside the period); a wrong gain or uncancelled d would give >= 1e-3.
    assert measured["deviation"] < 1e-5
    # It reaches the band K dt at |s(0)| / K (measured 1.001 s for K = 1, 0.501 s for K = 2) ...
    t_reach = measured["t_reach"][0]
    assert t_reach == pytest.approx(abs(s[0]) / K, abs=3 * DT)
    # ... and stays in it (measured max |s| / (K dt) = 0.9994 for K = 1, 0.70 for K = 2).
    assert measured["band_ratio"] <= 1.01

    # On the surface the tracking errors converge: 0.5 s after reaching, measured max |e| 6.1e-6 rad and
    # max |e_dot| 1.47e-3 rad/s for K = 1 (1.1e-5 and 3.2e-3 for K = 2): both scale with the band K dt.
    settled = t >= t_reach + 0.5
    assert np.abs(run["e"][settled]).max() < 1.5e-5 * K
    assert np.abs(run["e_dot"][settled]).max() < 4e-3 * K


@pytest.mark.slow  # a closed-loop run of seconds
def test_no_compensation_tracks_only_with_a_large_gain_and_chatters_more():
    """Remark 5.5: compensating the injection lets a small switching gain work, with much less chattering.

    Compared over one full period of d(t) after 1.5 s (the chattering depends on d's value)."""
    T = 1.5 + 2 * np.pi
    compensated = simulate(make(), T=T)  # K = 1
    uncompensated = simulate(make(bound=3.5, compensation="none"), T=T)  # K = 4 >= max |d| + mu
    too_small = simulate(make(compensation="none"), T=T)  # K = 1 < max |d| = 3
    window = compensated["t"] >= 1.5

    # Measured max |e| in the window: 6.1e-6 (compensated), 2.8e-5 (none, K = 4), 0.013 (none, K = 1);
    # max |e_dot|: 1.5e-3, 6.3e-3, 0.017.
    assert np.abs(compensated["e"][window]).max() < 2e-5
    assert np.abs(uncompensated["e"][window]).max() < 1e-4
    assert np.abs(uncompensated["e_dot"][window]).max() < 0.02
    assert np.abs(too_small["e"][window]).max() > 3e-3
    # Without compensation and K = 1 the sliding variable leaves the K dt band (measured max |s| 5.0).
    assert np.abs(too_small["s"][window]).max() > 5 * DT

    # Torque total variation: measured 26751 (compensated) vs 67422 (none, K = 4), ratio 2.52; the largest
    # jump per period: 4.28 vs 16.97 (each switch moves tau by about 2 m K).
    tv_compensated = total_variation(compensated["tau"][window])
    tv_uncompensated = total_variation(uncompensated["tau"][window])
    assert tv_uncompensated > 2.0 * tv_compensated
    jump_compensated = np.abs(np.diff(compensated["tau"][window], axis=0)).max()
    jump_uncompensated = np.abs(np.diff(uncompensated["tau"][window], axis=0)).max()
    assert jump_uncompensated > 3.0 * jump_compensated


def test_controller_math_on_batched_arrays():
    n = 2
    batched = NFTSMC(NFTSMC.Config.model_validate(GAINS, context={"n_joints": n}), n, DT, members=n)
    M = np.array([[2.0, 0.4], [0.4, 1.0]])
    step = fake_step(M, psi_hat=[0.3, -1.7])
    observer = FakeObserver(n)
    observer.qd_hat = np.array([[0.5, 0.2], [-0.1, 0.4]])
    q = np.array([[0.3, -0.1], [0.0, 0.2]])
    zeros = np.zeros((n, n))
    tau = batched.compute(0.0, zeros, zeros, zeros, q, observer, step).copy()
    for b in range(n):
        single = make(n)
        row_observer = FakeObserver(n)
        row_observer.qd_hat[:] = observer.qd_hat[b]
        expected = single.compute(0.0, zeros[b], zeros[b], zeros[b], q[b], row_observer, step)
        np.testing.assert_allclose(tau[b], expected, rtol=1e-12)


# --------------------------------------------------------------------------------------------------
# A-NFTSMC, (2.32)-(2.36) and the dead-zone law (2.43)

ADAPTIVE = {**{k: v for k, v in GAINS.items() if k != "bound"}, "rho": 2.0}  # K_hat replaces the bound


def make_adaptive(n_joints: int = 1, **overrides) -> AdaptiveNFTSMC:
    return closed_loop.make(AdaptiveNFTSMC, n_joints, **{**ADAPTIVE, **overrides})


@pytest.mark.parametrize(
    "change",
    [
        {"rho": None},  # missing
        {"rho": 0.0},  # rho > 0
        {"dead_zone": -0.01},
        {"initial_gain": [0.1, 0.2]},  # wrong length for 3 joints
        {"bound": 0.5},  # not a key: K_hat is adapted
    ],
)
def test_adaptive_config_errors_raise_validation_error(change):
    gains = {k: v for k, v in {**ADAPTIVE, **change}.items() if v is not None}
    with pytest.raises(ValidationError):
        AdaptiveNFTSMC.Config.model_validate(gains, context={"n_joints": 3})


def test_adaptive_gain_by_hand():
    """Per period: u_sw = (K_hat + mu) sign(s) with this period's K_hat, then K_hat += rho |s| dt (2.35), (2.36).
    ``signals["switching_gain"]`` is K_hat itself, updated in place; reset restores ``initial_gain``."""
    rho, initial, mu = np.array([2.0, 5.0]), np.array([0.3, 0.0]), 0.25
    controller = make_adaptive(2, **SURFACE, mu=mu, rho=list(rho), initial_gain=list(initial))
    signal = controller.signals["switching_gain"]
    np.testing.assert_array_equal(signal, initial)
    gain, integral = initial.copy(), np.zeros(2)
    for inputs in PERIODS:
        period = Period("injection", **inputs)
        A = rate_by_hand(period)
        s = period.e_dot + integral
        tau = period.compute(controller)
        np.testing.assert_allclose(tau, period.expected(A, gain + mu, s), rtol=1e-13)
        gain = gain + rho * np.abs(s) * DT
        assert controller.signals["switching_gain"] is signal
        np.testing.assert_allclose(signal, gain, rtol=1e-14)
        integral = integral + DT * A
    assert np.all(gain > initial)
    controller.reset()
    np.testing.assert_array_equal(signal, initial)
    assert controller.signals["switching_gain"] is signal


def test_dead_zone_stops_the_adaptation_below_epsilon():
    """(2.43): K_hat grows by rho |s| dt only on joints where |s| >= epsilon."""
    controller = make_adaptive(2, dead_zone=0.01)
    period = Period("injection", qd_hat=(0.205, -0.3))  # s = e_hat = [0.005, -0.6]
    period.compute(controller)
    np.testing.assert_allclose(controller.sliding, [0.005, -0.6], rtol=1e-12)
    np.testing.assert_allclose(controller.gain_estimate, [0.0, 2.0 * 0.6 * DT], rtol=1e-14)


@pytest.mark.parametrize("dead_zone", [0.0, 0.01])
def test_adaptive_reaching_law_and_drift(dead_zone):
    """From K_hat(0) = 0 the gain grows while s is far from 0; s obeys ds/dt = -(K_hat + mu) sign(s) with the
    period's gain. Without a dead zone K_hat keeps drifting on the surface (Remark 2.5); with epsilon = 0.01 >
    K dt it stops once |s| < epsilon."""
    controller = make_adaptive(dead_zone=dead_zone)
    run = simulate(controller, T=2.5, ed0=1.0)
    s, t, recorded = run["s"][:, 0], run["t"], run["switching_gain"][:, 0]  # K_hat after each period
    gain = np.concatenate([[0.0], recorded[:-1]])  # K_hat at the start of each period
    if dead_zone == 0.0:
        # K_hat' = rho |s| every period, up to rounding in K_hat ~ 1 (measured 1.1e-16).
        np.testing.assert_allclose(np.diff(recorded), 2.0 * np.abs(s[1:]) * DT, rtol=0, atol=1e-15)

    measured = reaching(run, gain[:-1, None] + ADAPTIVE["mu"])
    assert measured["deviation"] < 4e-6  # measured 1.25e-6
    t_reach = measured["t_reach"][0]
    assert 0.7 < t_reach < 1.0  # measured 0.870 s (0.501 s with a fixed K = 2)
    assert measured["band_ratio"] < 1.05  # measured 1.0002 (no dead zone), 0.9996
    after = t >= t_reach
    # K_hat at reaching: measured 1.0021 (both); growth after: 2.4e-3 (no dead zone), exactly 0 (dead zone).
    assert recorded[after][0] == pytest.approx(1.0, abs=0.05)
    drift = recorded[-1] - recorded[after][0]
    if dead_zone:
        assert drift == 0.0
    else:
        assert 1e-3 < drift < 5e-3
    # Measured max |e| 0.5 s after reaching: 1.05e-5 rad (both).
    assert np.abs(run["e"][t >= t_reach + 0.5]).max() < 3e-5


def test_adaptive_controller_on_batched_arrays():
    """As NFTSMC above: gains validated for n joints, ``members`` gives a batched controller.
    Regression: ``initial_gain`` used to stay (n,), and K_hat's in-place update with the (batch, n) rate failed."""
    config = AdaptiveNFTSMC.Config.model_validate({**ADAPTIVE, "initial_gain": 0.3}, context={"n_joints": 2})
    controller = AdaptiveNFTSMC(config, 2, DT, members=3)
    observer = FakeObserver((3, 2))
    observer.qd_hat[:] = [0.1, -0.2]  # s = e_hat at the first period
    zeros = np.zeros((3, 2))
    controller.compute(0.0, zeros, zeros, zeros, zeros, observer, fake_step(np.eye(2)))
    np.testing.assert_allclose(controller.gain_estimate, 0.3 + 2.0 * DT * np.abs(observer.qd_hat), rtol=1e-14)
