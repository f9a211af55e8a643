"""The example observer: its LUaF estimate follows a constant disturbance, its gains are the polynomial's, and a
batch of members with their own gains gives each member's single run bit for bit (ftc_mj.testing's check)."""

import numpy as np

from ftc_mj.testing import assert_batch_equals_single
from ftc_mj_pole_eso.observer import PoleESO, PoleESOConfig


class ExactModel:
    """A nominal model of two free masses: Psi = 0 and M = identity."""

    def __init__(self, shape):
        self.psi_hat = np.zeros(shape)

    def command_acceleration(self, tau):
        return tau


def simulate(bandwidth, damping, steps=3000, dt=1e-3, disturbance=2.0):
    shape = (2,)
    config = PoleESOConfig.model_validate(dict(bandwidth=bandwidth, damping=damping), context={"n_joints": 2})
    observer = PoleESO(config, 2, dt)
    observer.reset(np.zeros(shape), np.zeros(shape))
    model = ExactModel(shape)
    q, qd, tau = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    for k in range(steps):
        observer.update(k * dt, q, model)
        observer.advance(tau, model)
        qd = qd + dt * disturbance  # the true plant: qdd = tau + disturbance
        q = q + dt * qd
    return observer


def test_the_luaf_estimate_follows_a_constant_disturbance():
    observer = simulate(40.0, 0.7)
    np.testing.assert_allclose(observer.luaf_hat, 2.0, rtol=1e-3)


def test_gains_are_the_characteristic_polynomial():
    observer = PoleESO(PoleESOConfig(bandwidth=np.full(2, 10.0), damping=np.full(2, 0.5)), 2, 1e-3)
    # (s + 10)(s^2 + 10 s + 100) = s^3 + 20 s^2 + 200 s + 1000
    np.testing.assert_array_equal(observer.l1, 20.0)
    np.testing.assert_array_equal(observer.l2, 200.0)
    np.testing.assert_array_equal(observer.l3, 1000.0)


def test_a_member_of_a_batch_is_its_single_run():
    """Three members with their own gains (not as many as the joints), each against its run alone."""
    assert_batch_equals_single(PoleESO, [dict(bandwidth=20.0, damping=0.5), dict(bandwidth=40.0, damping=0.7),
                                         dict(bandwidth=80.0, damping=1.0)], n_joints=2, periods=500)
