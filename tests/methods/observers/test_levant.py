"""Levant's robust exact differentiator (Levant 2003, eqs. (8)-(9)): exact on a polynomial of its order after
convergence, to the discrete-time accuracy of its discretisation; one period by hand; the LUaF estimate with the
nominal model; the schema.

On a polynomial f of degree r (f^(r+1) = 0, so any L bounds it) sampled at tau:

* ``taylor`` (Livne and Levant 2014) is exact up to |z_i - f^(i)| <= C L tau^(r+1-i), the accuracy of Levant
  2003's Theorem 3; measured C <= 3.5 (r = 2) and <= 10.2 (r = 3) at tau = 1 ms, asserted with C = 20;
* ``euler`` keeps that accuracy for z0 and zr, while z_i (0 < i < r) lags f^(i) by about tau f^(i+1) / 2
  (the difference quotient of the line above): asserted within tau max|f^(i+1)| + C L tau^(r+1-i).
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from double_integrator import FakeStepModel

from ftc_mj.methods.observers import Levant

C = 20.0
CUBIC = np.polynomial.Polynomial([0.5, 0.3, -0.4, 0.2])


def make(n_joints: int = 1, dt: float = 1e-3, **gains) -> Levant:
    return Levant(Levant.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, dt)


def run_on(f: np.polynomial.Polynomial, observer: Levant, dt: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """The differentiator on f from the wrong state (z0 = f(0), z1 = 0, higher 0); times and errors z_i - f^(i)."""
    order = observer.differentiator.order
    observer.reset(np.array([f(0.0)]), np.array([0.0]))
    t = np.arange(int(round(duration / dt))) * dt
    derivatives = [f.deriv(i) if i else f for i in range(order + 1)]
    errors = np.empty((len(t), order + 1))
    for k, time in enumerate(t):
        observer.update(time, np.array([f(time)]), None)
        errors[k] = [z[0] - d(time) for z, d in zip(observer.differentiator.z, derivatives)]
        observer.advance(np.zeros(1), None)
    return t, errors


@pytest.mark.parametrize("order", [2, 3])
@pytest.mark.parametrize("discretisation", ["taylor", "euler"])
def test_exact_on_a_polynomial_of_its_order_after_convergence(order, discretisation):
    dt, L = 1e-3, 100.0
    f = np.polynomial.Polynomial(CUBIC.coef[:order + 1])
    t, errors = run_on(f, make(order=order, L=L, discretisation=discretisation), dt, 5.0)
    late = t >= 3.0  # converged well before (about 1.5 s for r = 3)
    bound = np.array([C * L * dt ** (order + 1 - i) for i in range(order + 1)]) + 1e-12
    if discretisation == "euler":  # the lag of the intermediate estimates
        lag = [dt * np.abs(f.deriv(i + 1)(t[late])).max() if 0 < i < order else 0.0 for i in range(order + 1)]
        bound = bound + np.array(lag)
    worst = np.abs(errors[late]).max(axis=0)
    assert (worst <= bound).all(), (worst, bound)
    assert np.abs(errors[:10, 1]).max() > 0.1  # it did start wrong


@pytest.mark.slow  # a closed-loop run of seconds
def test_euler_lags_and_taylor_does_not():
    """The documented O(tau) lag of explicit Euler on z1: about tau f''/2, which the Taylor terms remove."""
    dt, f = 1e-3, np.polynomial.Polynomial([0.5, 0.3, -0.4])  # f'' = -0.8
    _, euler = run_on(f, make(order=2, L=10.0), dt, 4.0)  # L small: the chattering (L tau^2) below the lag
    _, taylor = run_on(f, make(order=2, L=10.0, discretisation="taylor"), dt, 4.0)
    assert np.abs(euler[-1000:, 1]).max() == pytest.approx(dt * 0.8 / 2, rel=0.1)  # measured 4.19e-4
    assert np.abs(taylor[-1000:, 1]).max() < 0.2 * np.abs(euler[-1000:, 1]).max()  # measured 3.4e-5


def test_finite_time_convergence_from_a_wrong_start():
    """Exact (to its accuracy) after a finite time, not asymptotically: once converged the error stays there."""
    dt, L = 1e-3, 100.0
    f = np.polynomial.Polynomial([0.2, -1.0, 0.5])
    t, errors = run_on(f, make(order=2, L=L, discretisation="taylor"), dt, 3.0)
    inside = np.abs(errors[:, 2]) <= C * L * dt
    first = np.argmax(inside & np.flip(np.cumprod(np.flip(inside)) > 0))  # from here on always inside
    assert 0 < t[first] < 1.5


def test_one_period_by_hand():
    """Order 2, eqs. (8)-(9) with lambda_2, lambda_1, lambda_0 = 2, 1.5, 1.1 and one Euler step."""
    L = np.array([4.0, 9.0])
    observer = make(2, dt=1e-3, order=2, L=L.tolist())
    observer.reset(np.array([0.1, -0.2]), np.array([0.5, 1.0]))
    observer.differentiator.z[2][:] = [0.3, -0.7]
    z0, z1, z2 = (z.copy() for z in observer.differentiator.z)
    f = np.array([0.12, -0.25])
    observer.update(0.0, f, None)
    e0 = z0 - f
    v0 = -2.0 * L ** (1 / 3) * np.abs(e0) ** (2 / 3) * np.sign(e0) + z1
    e1 = z1 - v0
    v1 = -1.5 * L ** 0.5 * np.abs(e1) ** 0.5 * np.sign(e1) + z2
    v2 = -1.1 * L * np.sign(z2 - v1)
    for v, expected in zip(observer.differentiator.rates, (v0, v1, v2)):
        np.testing.assert_allclose(v, expected, rtol=1e-13)
    observer.advance(np.zeros(2), None)
    np.testing.assert_allclose(observer.q_hat, z0 + 1e-3 * v0, rtol=1e-14)
    np.testing.assert_allclose(observer.qd_hat, z1 + 1e-3 * v1, rtol=1e-14)
    np.testing.assert_array_equal(observer.luaf_hat, 0.0)  # model-free
    np.testing.assert_array_equal(observer.injection, 0.0)


def test_luaf_with_the_model_is_the_acceleration_minus_the_nominal_one():
    """luaf_hat = z2 - (Psi(z0, z1) + M^-1 u of the previous period); the injection is that estimate."""
    observer = make(1, order=2, L=10.0, use_model=True)
    observer.reset(np.array([0.0]), np.array([0.0]))
    M, psi = np.array([[2.0]]), [0.4]
    step = FakeStepModel(M, psi_hat=psi)
    observer.update(0.0, np.array([0.0]), step)
    np.testing.assert_allclose(observer.luaf_hat, -0.4)  # z2 = 0, no command yet
    observer.advance(np.array([3.0]), step)
    observer.update(1e-3, np.array([1e-6]), step)
    expected = observer.differentiator.z[2] - 0.4 - 3.0 / 2.0
    np.testing.assert_allclose(observer.luaf_hat, expected, rtol=1e-14)
    np.testing.assert_array_equal(observer.injection, observer.luaf_hat)


def test_gains_and_schema():
    observer = make(3, order=3, L=[1.0, 8.0, 27.0], lambda0=1.2)
    k = observer.differentiator.gains
    np.testing.assert_allclose(k[0], 3.0 * np.array([1.0, 8.0, 27.0]) ** 0.25)  # lambda_3 L^(1/4)
    np.testing.assert_allclose(k[3], 1.2 * np.array([1.0, 8.0, 27.0]))  # lambda_0 L
    assert make(order="2", L=1.0).differentiator.order == 2
    for gains in ({"L": 1.0, "order": 1, "use_model": True}, {"L": 1.0, "order": 6}, {"order": 2},
                  {"L": -1.0}, {"L": 1.0, "lambda9": 1.0}, {"L": 1.0, "discretisation": "rk4"}):
        with pytest.raises(ValidationError):
            Levant.Config.model_validate(gains, context={"n_joints": 3})
