"""The disturbance Kalman filter's own state: the initial covariance where each variance belongs, no period
before a steady state is found, reset clears the innovation, the injection is the LUaF estimate, and a steady
state of period 3 (where replaying the gains in the wrong order shows) replays the full recursion bit for bit."""

from __future__ import annotations

import numpy as np

from double_integrator import DT, FakeStepModel

from ftc_mj.methods.observers import KalmanObserver


def make(cls=KalmanObserver, n_joints: int = 1, **gains) -> KalmanObserver:
    return cls(KalmanObserver.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


class FullRecursion(KalmanObserver):
    window = 0  # never replays


def test_reset_starts_from_the_initial_variances_on_the_diagonal():
    observer = make(n_joints=2, process_d=10.0, measurement=1e-8, initial_q=2e-6, initial_qd=[3.0, 4.0],
                    initial_d=50.0)
    assert observer.period is None
    observer.innovation[:] = 7.0
    observer.reset(np.zeros(2), np.zeros(2))
    P = observer.covariance
    for j, qd in enumerate((3.0, 4.0)):
        np.testing.assert_array_equal(P[j], np.diag([2e-6, qd, 50.0]))
    np.testing.assert_array_equal(observer.innovation, 0.0)


def test_the_injection_is_the_luaf_estimate():
    observer = make(n_joints=2, process_d=10.0, measurement=1e-8)
    observer.reset(np.zeros(2), np.zeros(2))
    observer.luaf_hat[:] = [0.4, -1.5]
    observer.update(0.0, np.zeros(2), FakeStepModel(np.eye(2)))
    np.testing.assert_array_equal(observer.injection, [0.4, -1.5])


def test_a_steady_state_of_period_three_replays_in_order():
    """These covariances end in a cycle of three periods (found by a search on this recursion: the
    prediction repeats after about 120 periods); the replayed gains must follow the cycle's order."""
    gains = dict(process_d=41.515221489404084, measurement=2.3068118966284397e-11)
    replayed, full = make(**gains), make(FullRecursion, **gains)
    step = FakeStepModel(np.array([[2.0]]), psi_hat=[0.1])
    rng = np.random.default_rng(4)
    for observer in (replayed, full):
        observer.reset(np.zeros(1), np.zeros(1))
    y = np.zeros(1)
    for k in range(200):
        y = y + rng.normal(scale=1e-4, size=1)
        tau = rng.normal(size=1)
        for observer in (replayed, full):
            observer.measure(y, None)
            observer.update(k * DT, y, step)
            observer.advance(tau, step)
        np.testing.assert_array_equal(replayed.state, full.state, err_msg=f"period {k}")
        np.testing.assert_array_equal(replayed.covariance, full.covariance, err_msg=f"period {k}")
    assert replayed.period == 3 and full.period is None
