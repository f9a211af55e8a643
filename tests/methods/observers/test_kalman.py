"""The disturbance Kalman filter: the exact discretisation of its covariances, the covariance update against
the textbook matrix form, convergence to a constant disturbance, white innovations when the plant is the
filter's own model (normalised autocorrelation at lags 1-20 within 3 / sqrt(N)), the steady state's
replayed gains against the full recursion, bit for bit (also in a cycle of three periods, where the order of
the replay shows); the initial covariance, the reset innovation and the injection."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from double_integrator import DT, FakeStepModel

from ftc_mj.methods.observers import BUILTIN, KalmanObserver
from ftc_mj.methods.observers.kalman import pack, process_covariance, unpack

F = np.array([[1.0, DT, DT**2 / 2], [0.0, 1.0, DT], [0.0, 0.0, 1.0]])


def make(n_joints: int = 1, **gains) -> KalmanObserver:
    return KalmanObserver(KalmanObserver.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def test_process_covariance_is_van_loans_integral():
    densities = np.array([1e-4, 0.3, 50.0])
    A = np.diag([1.0, 1.0], k=1)
    block = np.block([[-A, np.diag(densities)], [np.zeros((3, 3)), A.T]]) * DT  # Van Loan 1978
    E = expm(block)
    expected = E[3:, 3:].T @ E[:3, 3:]
    got = process_covariance(DT, *densities, shape=(1,))[0]
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-24)


def test_one_period_against_the_matrix_form():
    """measure (x += K nu, P = (I - K H) P) and advance (x = F x + B u, P = F P F^T + Q) as matrices."""
    observer = make(2, process_q=1e-6, process_qd=0.1, process_d=30.0, measurement=1e-8, initial_qd=[2.0, 3.0])
    rng = np.random.default_rng(1)
    observer.reset(np.array([0.1, -0.2]), np.array([0.5, 0.0]))
    A = rng.normal(size=(2, 3, 3))
    observer.entries[:] = pack(A @ A.transpose(0, 2, 1) + np.eye(3))
    P0, x0 = observer.covariance, np.stack([observer.q_hat, observer.qd_hat, observer.luaf_hat], -1)
    y = np.array([0.11, -0.19])
    H = np.array([[1.0, 0.0, 0.0]])
    observer.measure(y, None)
    M, psi, tau = np.array([[2.0, 0.3], [0.3, 1.0]]), np.array([0.4, -0.1]), np.array([1.0, -2.0])
    step = FakeStepModel(M, psi_hat=psi)
    observer.update(0.0, y, step)
    observer.advance(tau, step)
    u = psi + np.linalg.solve(M, tau)
    for j in range(2):
        S = (H @ P0[j] @ H.T)[0, 0] + 1e-8
        K = P0[j] @ H.T / S
        x = x0[j] + K[:, 0] * (y[j] - x0[j, 0])
        P = (np.eye(3) - K @ H) @ P0[j]
        x = F @ x + np.array([DT**2 / 2, DT, 0.0]) * u[j]
        P = F @ P @ F.T + unpack(observer.process)[j]
        np.testing.assert_allclose([observer.q_hat[j], observer.qd_hat[j], observer.luaf_hat[j]], x, rtol=1e-12)
        np.testing.assert_allclose(observer.covariance[j], P, rtol=1e-10)
    np.testing.assert_array_equal(observer.innovation, y - x0[:, 0])
    assert observer.signals["innovation"] is observer.innovation


def run(observer: KalmanObserver, d: float, steps: int, rng=None, Q=None, R=0.0):
    """The plant x(k+1) = F x + B u + w, y = q + v (the filter's model when w ~ N(0, Q), v ~ N(0, R)), one
    joint of inertia 2 with a known torque; estimates of d and innovations per period."""
    step = FakeStepModel(np.array([[2.0]]), psi_hat=[0.1])
    x = np.array([0.3, -0.2, d])
    observer.reset(x[:1].copy(), np.array([0.0]))
    estimates, innovations = np.empty(steps), np.empty(steps)
    for k in range(steps):
        y = x[0] + (rng.normal() * np.sqrt(R) if rng is not None else 0.0)
        observer.measure(np.array([y]), None)
        observer.update(k * DT, np.array([y]), step)
        estimates[k], innovations[k] = observer.luaf_hat[0], observer.innovation[0]
        tau = np.sin(2.0 * k * DT)
        u = 0.1 + tau / 2.0
        x = F @ x + np.array([DT**2 / 2, DT, 0.0]) * u
        if rng is not None:
            x = x + rng.multivariate_normal(np.zeros(3), Q)
        observer.advance(np.array([tau]), step)
    return estimates, innovations


def test_the_estimate_of_a_constant_disturbance_converges():
    observer = make(process_d=10.0, measurement=1e-10)
    estimates, _ = run(observer, 2.5, 2000)
    t = np.arange(2000) * DT
    assert abs(estimates[0]) < 1e-9  # from zero
    settled = np.abs(estimates - 2.5) < 1e-3
    assert settled[t >= 0.1].all()  # measured: within 1e-3 from 16 ms
    assert abs(estimates[-1] - 2.5) < 1e-6


@pytest.mark.slow  # a closed-loop run of seconds
def test_innovations_are_white_when_the_plant_is_the_model():
    densities, R = (1e-8, 1e-3, 20.0), 1e-10
    observer = make(process_q=densities[0], process_qd=densities[1], process_d=densities[2], measurement=R)
    Q = process_covariance(DT, *densities, shape=(1,))[0]
    _, innovations = run(observer, 1.0, 6000, np.random.default_rng(5), Q, R)
    nu = innovations[1000:]  # after the filter's transient
    nu = nu - nu.mean()
    N = len(nu)
    rho = np.array([np.dot(nu[:-lag], nu[lag:]) for lag in range(1, 21)]) / np.dot(nu, nu)
    assert np.abs(rho).max() < 3.0 / np.sqrt(N), rho  # measured: 1.6 / sqrt(N)


@pytest.mark.slow  # a closed-loop run of seconds
def test_innovations_are_not_white_when_the_model_is_wrong():
    """The whiteness test can fail: a filter that believes d is constant (tiny process_d) against a d that moves."""
    densities, R = (1e-8, 1e-3, 20.0), 1e-10
    observer = make(process_q=densities[0], process_qd=densities[1], process_d=1e-6, measurement=R)
    Q = process_covariance(DT, *densities, shape=(1,))[0]
    _, innovations = run(observer, 1.0, 6000, np.random.default_rng(5), Q, R)
    nu = innovations[1000:] - innovations[1000:].mean()
    assert abs(np.dot(nu[:-1], nu[1:]) / np.dot(nu, nu)) > 3.0 / np.sqrt(len(nu))


class FullRecursion(KalmanObserver):
    window = 0  # never replays


def replay_against_the_full_recursion(gains: dict, n: int, steps: int, seed: int) -> tuple[KalmanObserver, int | None]:
    """The filter with the steady state's replay and without it on the same arbitrary readings and torques,
    their estimates and covariances equal to the bit every period; the replaying one and the period in which it
    found its steady state (None if it did not)."""
    replayed = make(n, **gains)
    full = FullRecursion(KalmanObserver.Config.model_validate(gains, context={"n_joints": n}), n, DT)
    step = FakeStepModel(np.diag([2.0, 1.0, 0.5][:n]), psi_hat=[0.1, -0.3, 0.2][:n])
    rng = np.random.default_rng(seed)
    for observer in (replayed, full):
        observer.reset(np.zeros(n), np.full(n, 0.5))
    y, found = np.zeros(n), None
    for k in range(steps):
        y = y + rng.normal(scale=1e-4, size=n)
        tau = rng.normal(size=n)
        for observer in (replayed, full):
            observer.measure(y, None)
            observer.update(k * DT, y, step)
            observer.advance(tau, step)
        np.testing.assert_array_equal(replayed.state, full.state, err_msg=f"period {k}")
        np.testing.assert_array_equal(replayed.covariance, full.covariance, err_msg=f"period {k}")
        if found is None and replayed.period is not None:
            found = k
    assert full.period is None
    return replayed, found


@pytest.mark.slow  # a closed-loop run of seconds
def test_the_steady_state_replays_the_recursion_bit_for_bit():
    """Once the prediction's covariance repeats, the stored gains replace the recursion: the estimates and
    covariances are those of the full recursion to the bit, on arbitrary readings, for joints of different
    covariances (their periods differ)."""
    gains = dict(process_d=[10.0, 300.0, 3600.0], process_qd=[0.0, 1.0, 0.1], measurement=[1e-9, 8.7e-10, 1e-10])
    replayed, found = replay_against_the_full_recursion(gains, 3, 3000, 3)
    assert found is not None and found < 2000  # measured: period 2 from step 985
    replayed.reset(np.zeros(3), np.zeros(3))
    assert replayed.period is None and np.array_equal(replayed.covariance, unpack(replayed.initial))


def test_a_steady_state_of_period_three_replays_in_order():
    """These covariances end in a cycle of three periods (found by a search on this recursion: the prediction
    repeats after about 120 periods), where replaying the stored gains in another order than the cycle's
    shows (in a cycle of two, backwards is forwards)."""
    gains = dict(process_d=41.515221489404084, measurement=2.3068118966284397e-11)
    replayed, found = replay_against_the_full_recursion(gains, 1, 200, 4)
    assert replayed.period == 3 and found < 150  # measured: from step 122


def test_reset_starts_from_the_initial_variances_on_the_diagonal():
    observer = make(2, process_d=10.0, measurement=1e-8, initial_q=2e-6, initial_qd=[3.0, 4.0],
                    initial_d=50.0)
    assert observer.period is None
    observer.innovation[:] = 7.0
    observer.reset(np.zeros(2), np.zeros(2))
    P = observer.covariance
    for j, qd in enumerate((3.0, 4.0)):
        np.testing.assert_array_equal(P[j], np.diag([2e-6, qd, 50.0]))
    np.testing.assert_array_equal(observer.innovation, 0.0)


def test_the_injection_is_the_luaf_estimate():
    observer = make(2, process_d=10.0, measurement=1e-8)
    observer.reset(np.zeros(2), np.zeros(2))
    observer.luaf_hat[:] = [0.4, -1.5]
    observer.update(0.0, np.zeros(2), FakeStepModel(np.eye(2)))
    np.testing.assert_array_equal(observer.injection, [0.4, -1.5])


def test_schema():
    assert BUILTIN["kalman"] is KalmanObserver and KalmanObserver.requires == {"position"}
    for gains in ({"measurement": 1e-8}, {"process_d": 1.0}, {"process_d": 0.0, "measurement": 1e-8},
                  {"process_d": 1.0, "measurement": 1e-8, "process_q": -1.0}):
        with pytest.raises(ValueError):
            KalmanObserver.Config.model_validate(gains, context={"n_joints": 1})
