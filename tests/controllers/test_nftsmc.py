"""Observer-based NFTSMC, eqs. (5.14)-(5.27), on a plant-free double integrator.

Plant: one joint, qdd = tau / m + d(t), d(t) = 2 sin t + 1, integrated exactly over each control period.
The observer is a fake with exact estimates: ``qd_hat`` is the true velocity and the injection (and the LUaF
estimate) is the true d(t) at the sample, so that with ``compensation: injection`` eq. (5.32) holds with
delta = 0 and the sliding variable obeys ds/dt = -(bound + mu) sign(s): per period s_{k+1} - s_k =
-(bound + mu) dt sign(s_k), up to O(dt^2) from d and the reference varying inside the period.

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from ftc_mj.controllers import NFTSMC

DT = 1e-3
MASS = 2.0
GAINS = dict(beta1=15.0, beta2=10.0, beta3=10.0, beta4=5.0, gamma1=0.5, bound=0.5, mu=0.5)  # the scenario's


class FakeStepModel:
    def __init__(self, M, psi_hat=None):
        self.M = np.asarray(M, dtype=float)
        self.psi_hat = np.zeros(len(self.M)) if psi_hat is None else np.asarray(psi_hat, dtype=float)

    def solve_M(self, v):
        return np.linalg.solve(self.M, v)


class FakeObserver:
    """Only the attributes a controller reads."""

    def __init__(self, n: int = 1):
        self.q_hat = np.zeros(n)
        self.qd_hat = np.zeros(n)
        self.luaf_hat = np.zeros(n)
        self.injection = np.zeros(n)


def d(t):
    return 2.0 * np.sin(t) + 1.0


def d_int1(t):
    return 2.0 * (1.0 - np.cos(t)) + t


def d_int2(t):
    return 2.0 * (t - np.sin(t)) + 0.5 * t * t


def reference(t):
    return 0.5 * np.sin(t), 0.5 * np.cos(t), -0.5 * np.sin(t)


def make(n_joints: int = 1, **overrides) -> NFTSMC:
    gains = {**GAINS, **overrides}
    return NFTSMC(NFTSMC.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def simulate(controller, *, T=2.5, e0=0.2, ed0=1.0, injection=None, luaf_hat=None) -> dict:
    """Closed loop on the exact double integrator with exact estimates.

    ``injection`` / ``luaf_hat`` override what the fake observer reports (default: the true d(t))."""
    observer, step = FakeObserver(), FakeStepModel(MASS * np.eye(1))
    q_ref, qd_ref, _ = reference(0.0)
    q, v = q_ref + e0, qd_ref + ed0
    n = int(round(T / DT))
    out = {key: np.empty(n) for key in ("t", "e", "e_dot", "s", "tau")}
    for k in range(n):
        t = k * DT
        q_ref, qd_ref, qdd_ref = reference(t)
        observer.qd_hat[0] = v
        observer.injection[0] = d(t) if injection is None else injection
        observer.luaf_hat[0] = d(t) if luaf_hat is None else luaf_hat
        tau = controller.compute(
            t, np.array([q_ref]), np.array([qd_ref]), np.array([qdd_ref]), np.array([q]), observer, step
        )[0]
        for key, value in zip(out, (t, q - q_ref, v - qd_ref, controller.sliding[0], tau)):
            out[key][k] = value
        a, h = tau / MASS, DT
        q, v = (
            q + v * h + 0.5 * a * h * h + d_int2(t + h) - d_int2(t) - d_int1(t) * h,
            v + a * h + d_int1(t + h) - d_int1(t),
        )
    return out


def total_variation(x):
    return float(np.abs(np.diff(x)).sum())


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


@pytest.mark.parametrize("compensation", ["injection", "estimate", "none"])
def test_two_periods_by_hand(compensation):
    """tau = -M (u_eq + u_c + u_sw), u_eq = Psi(x_hat) + A - xdd_d, s = e_hat + integral of A (5.15)."""
    c = dict(beta1=[15.0, 3.0], beta2=[10.0, 2.0], beta3=[10.0, 1.0], beta4=[5.0, 0.5], gamma1=0.6)
    controller = make(2, **c, bound=[0.5, 1.0], mu=0.25, compensation=compensation)
    b1, b2, b3, b4 = (np.asarray(c[k]) for k in ("beta1", "beta2", "beta3", "beta4"))
    g1, g2 = 0.6, 2 * 0.6 / 1.6
    K = np.array([0.75, 1.25])
    M = np.array([[2.0, 0.4], [0.4, 1.0]])
    step = FakeStepModel(M, psi_hat=[0.3, -1.7])
    observer = FakeObserver(2)
    observer.injection[:] = [0.9, -2.0]
    observer.luaf_hat[:] = [0.6, -1.5]
    u_c = {"injection": observer.injection, "estimate": observer.luaf_hat, "none": 0.0}[compensation]

    integral = np.zeros(2)
    for q, qd_hat, (q_ref, qd_ref, qdd_ref) in [
        ([0.3, -0.1], [0.5, 0.2], ([0.1, 0.0], [0.2, 0.3], [-0.4, 1.0])),
        ([0.31, -0.09], [0.45, -0.1], ([0.11, 0.001], [0.25, 0.35], [-0.5, 0.9])),
    ]:
        q, q_ref, qd_ref, qdd_ref = map(np.asarray, (q, q_ref, qd_ref, qdd_ref))
        observer.qd_hat[:] = qd_hat
        e, e_hat = q - q_ref, observer.qd_hat - qd_ref  # (5.3), (5.14)
        A = b1 * np.abs(e) ** g1 * np.sign(e) + b2 * np.abs(e_hat) ** g2 * np.sign(e_hat) + b3 * e + b4 * e**3
        s = e_hat + integral  # the integral up to the previous period
        tau_expected = -M @ (step.psi_hat + A - qdd_ref + u_c + K * np.sign(s))

        tau = controller.compute(0.0, q_ref, qd_ref, qdd_ref, q, observer, step)
        np.testing.assert_allclose(controller.sliding, s, rtol=1e-13)
        np.testing.assert_allclose(tau, tau_expected, rtol=1e-13)
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
    s, t = run["s"], run["t"]
    assert s[0] == pytest.approx(1.0)  # s(0) = e_hat(0), the integral starts at 0
    band = K * DT

    reaching = np.abs(s[:-1]) > band
    # Per period s decreases by exactly K dt towards 0. Measured deviation 1.25e-6 (d and the reference
    # vary inside the period); a wrong gain or uncancelled d would give >= 1e-3.
    deviation = np.diff(s)[reaching] + band * np.sign(s[:-1][reaching])
    assert np.abs(deviation).max() < 1e-5

    # It reaches the band at |s(0)| / K (measured 1.001 s for K = 1, 0.501 s for K = 2) ...
    k_reach = int(np.argmax(np.abs(s) <= band))
    assert t[k_reach] == pytest.approx(abs(s[0]) / K, abs=3 * DT)
    # ... and stays in it (measured max |s| / (K dt) = 0.9994 for K = 1, 0.70 for K = 2).
    assert np.abs(s[k_reach:]).max() <= 1.01 * band

    # On the surface the tracking errors converge: 0.5 s after reaching, measured max |e| 6.1e-6 rad and
    # max |e_dot| 1.47e-3 rad/s for K = 1 (1.1e-5 and 3.2e-3 for K = 2): both scale with the band K dt.
    settled = t >= t[k_reach] + 0.5
    assert np.abs(run["e"][settled]).max() < 1.5e-5 * K
    assert np.abs(run["e_dot"][settled]).max() < 4e-3 * K


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
    jump_compensated = np.abs(np.diff(compensated["tau"][window])).max()
    jump_uncompensated = np.abs(np.diff(uncompensated["tau"][window])).max()
    assert jump_uncompensated > 3.0 * jump_compensated


def test_controller_math_on_batched_arrays():
    n = 2
    batched = NFTSMC(NFTSMC.Config.model_validate(GAINS, context={"n_joints": n}), (n, n), DT)
    M = np.array([[2.0, 0.4], [0.4, 1.0]])
    step = FakeStepModel(M, psi_hat=[0.3, -1.7])
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
