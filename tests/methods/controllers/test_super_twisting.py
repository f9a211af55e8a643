"""Super-twisting control on the exact closed loop of closed_loop.py (qdd = tau / m + d(t), d = 2 sin t + 1,
exact estimates): s reaches 0 in finite time, within the reaching-time bound of Moreno and Osorio's strict
Lyapunov function, and stays in a band of O(dt^2) (Levant 1993).

With ``compensation: injection`` the perturbation of the algorithm is rho = d(t) - d(t_k) = O(dt) (the fake
observer reports d at the sample); with ``none`` it is the whole d(t), |d rho/dt| = |2 cos t| <= 2 < L = 4.
Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from pydantic import ValidationError

import closed_loop
from closed_loop import DT, Period, make, simulate
from controller_batch import assert_batch_equals_single

from ftc_mj.methods.controllers import SuperTwisting

L = 4.0  # k1 = 1.5 L^(1/2) = 3, k2 = 1.1 L = 4.4
GAINS = dict(c=5.0, L=L)
S0 = 0.5  # s(0) = ed0 + c e0 = -0.5 + 5 * 0.2


def run(compensation: str, dt: float = DT, monkeypatch=None, T: float = 3.0) -> dict:
    if dt != DT:
        monkeypatch.setattr(closed_loop, "DT", dt)
    config = SuperTwisting.Config.model_validate({**GAINS, "compensation": compensation}, context={"n_joints": 1})
    return simulate(SuperTwisting(config, 1, dt), T=T, e0=0.2, ed0=-0.5)


def settling_time(run: dict, level: float) -> float:
    """The time from which |s| <= level for good (s crosses 0 several times while it twists in)."""
    above = np.nonzero(np.abs(run["s"][:, 0]) > level)[0]
    return float(run["t"][above[-1] + 1])


def lyapunov_reaching_bound(k1: float, k2: float, s0: float) -> float:
    """An upper bound on the reaching time of the unperturbed algorithm ds/dt = -k1 |s|^(1/2) sign(s) + v,
    dv/dt = -k2 sign(s) from (s0, v = 0), by Moreno and Osorio's V = zeta' P zeta, zeta = (|s|^(1/2) sign(s), v)
    (IEEE TAC 57(4), 2012): d zeta/dt = |s|^(-1/2) A zeta, A = [[-k1/2, 1/2], [-k2, 0]], A'P + PA = -I, so
    dV/dt = -|s|^(-1/2) |zeta|^2 <= -|zeta| <= -V^(1/2) / lambda_max(P)^(1/2) (|s|^(1/2) <= |zeta|), and
    V reaches 0 before T = 2 V(0)^(1/2) lambda_max(P)^(1/2)."""
    A = np.array([[-k1 / 2, 0.5], [-k2, 0.0]])
    P = scipy.linalg.solve_continuous_lyapunov(A.T, -np.eye(2))
    zeta = np.array([np.sqrt(abs(s0)) * np.sign(s0), 0.0])
    return float(2 * np.sqrt(zeta @ P @ zeta) * np.sqrt(np.linalg.eigvalsh(P).max()))


# --------------------------------------------------------------------------------------------------
# configuration and one period


def test_gains_from_levants_rule():
    config = SuperTwisting.Config.model_validate({"c": 2.0, "L": [4.0, 9.0, 25.0]}, context={"n_joints": 3})
    k1, k2 = config.gains()
    np.testing.assert_array_equal(k1, [3.0, 4.5, 7.5])  # 1.5 L^(1/2)
    np.testing.assert_allclose(k2, [4.4, 9.9, 27.5], rtol=1e-15)  # 1.1 L
    assert config.compensation == "none"
    explicit = SuperTwisting.Config.model_validate({"c": 2.0, "k1": 1.0, "k2": 2.0}).gains()
    assert [g.tolist() for g in explicit] == [[1.0], [2.0]]


@pytest.mark.parametrize(
    "gains",
    [
        {"L": 4.0},  # c missing
        {"c": 1.0},  # neither L nor k1, k2
        {"c": 1.0, "k1": 2.0},  # k2 missing
        {"c": 1.0, "L": 4.0, "k1": 2.0},  # both
        {"c": 0.0, "L": 4.0},
        {"c": 1.0, "L": -1.0},
        {"c": [1.0, 2.0], "L": 4.0},  # wrong length for 3 joints
        {"c": 1.0, "L": 4.0, "compensation": "tosmo"},
        {"c": 1.0, "L": 4.0, "mu": 0.5},  # unknown key
    ],
)
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        SuperTwisting.Config.model_validate(gains, context={"n_joints": 3})


@pytest.mark.parametrize("compensation", ["injection", "estimate", "none"])
def test_two_periods_by_hand(compensation):
    """tau = -M (Psi + c e_dot - xdd_d + u_c + k1 |s|^(1/2) sign(s) + z), z(0) = 0, z += dt k2 sign(s)."""
    c, k1, k2 = np.array([2.0, 3.0]), np.array([1.5, 2.5]), np.array([4.0, 7.0])
    controller = make(SuperTwisting, 2, c=list(c), k1=list(k1), k2=list(k2), compensation=compensation)
    period = Period(compensation, qd_hat=(-0.5, 0.7))  # e = [0.2, -0.1], e_dot = [-0.7, 0.4]
    s = period.e_dot + c * period.e
    assert np.sign(s).tolist() == [-1.0, 1.0]
    z = np.zeros(2)
    for _ in range(2):
        tau = period.compute(controller)
        np.testing.assert_allclose(controller.sliding, s, rtol=1e-14)
        u_sw = k1 * np.sqrt(np.abs(s)) * np.sign(s) + z
        np.testing.assert_allclose(tau, period.expected(c * period.e_dot, 0.0, s) - period.M @ u_sw, rtol=1e-13)
        z = z + DT * k2 * np.sign(s)
        np.testing.assert_allclose(controller.signals["twisting_integral"], z, rtol=1e-14)
    controller.reset()
    assert not controller.signals["twisting_integral"].any()


# --------------------------------------------------------------------------------------------------
# the defining property


@pytest.mark.slow  # a closed-loop run of seconds
def test_reaches_the_surface_within_the_lyapunov_bound(monkeypatch):
    """Unperturbed (exact injection): s reaches 0 in finite time, before Moreno and Osorio's bound. A finite
    time, not an asymptote: the time to gain each decade of |s| shrinks (the twisting's turns shrink
    geometrically), where an exponential approach spends ln(10) / rate on every decade. At dt = 0.25 ms, so
    that the sampling band (2e-7) is far below the levels."""
    result = run("injection", DT / 4, monkeypatch)
    bound = lyapunov_reaching_bound(1.5 * np.sqrt(L), 1.1 * L, S0)  # 4.86 s
    times = [settling_time(result, level) for level in (1e-2, 1e-3, 1e-4, 1e-5)]  # measured 0.526, 0.586,
    assert times[-1] < bound  # 0.605, 0.614 s
    assert times[3] - times[2] < 0.5 * (times[1] - times[0])  # measured 0.009 against 0.060 s


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.parametrize(("compensation", "band_at_dt"), [("injection", 1e-5), ("none", 3e-5)])
def test_sliding_band_shrinks_as_dt_squared(monkeypatch, compensation, band_at_dt):
    """Sampled super-twisting keeps |s| = O(dt^2) (Levant 1993) also under the whole LUaF (``none``, L above
    its rate). Measured max |s| after 1.5 s: injection 3.5e-6 at 1 ms, 8.7e-7 at 0.5 ms; none 1.1e-5, 2.8e-6.
    A first-order sliding mode (u_sw = K sign(s)) keeps |s| = O(dt) instead: a ratio of 2."""
    bands = []
    for dt in (DT, DT / 2):
        result = run(compensation, dt, monkeypatch)
        bands.append(np.abs(result["s"][result["t"] >= 1.5]).max())
    assert bands[0] < band_at_dt
    assert bands[0] / bands[1] > 3.0  # measured 4.0 (injection), 4.2 (none)


@pytest.mark.slow  # a closed-loop run of seconds
def test_reaching_time_does_not_depend_on_dt(monkeypatch):
    """Finite-time reaching under the whole LUaF (``none``): the time from which |s| <= 1e-4 converges as
    dt -> 0 (measured 0.606 s at 1 ms, 0.6055 s at 0.5 ms, 0.604 s at 0.25 ms); z takes over d(t) meanwhile."""
    times = [settling_time(run("none", dt, monkeypatch), 1e-4) for dt in (DT, DT / 2, DT / 4)]
    assert max(times) - min(times) < 0.01
    assert 0.3 < min(times) and max(times) < 1.0


def test_batch_equals_single_member_by_member():
    """5 members of a 3-joint law, each with its own c and L (or k1, k2), bit for bit alone."""
    members = [{"c": 5.0, "L": 4.0}, {"c": [2.0, 3.0, 4.0], "L": [1.0, 9.0, 30.0]}, {"c": 1.0, "L": 0.5},
               {"c": 5.0, "L": 4.5}, {"c": 8.0, "L": 22.0}]
    assert_batch_equals_single(SuperTwisting, members)
    explicit = [{"c": 5.0, "k1": 0.5 + m, "k2": 2.0 * m + 1.0, "compensation": "estimate"} for m in range(4)]
    assert_batch_equals_single(SuperTwisting, explicit, scale=1e-3)
