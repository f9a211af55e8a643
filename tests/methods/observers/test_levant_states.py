"""Levant's differentiator beyond its convergence: reset of every order puts z0 = position, z1 = velocity and the
higher states to 0; the top line's sign is that of z_r - v_(r-1) as computed (also where the lower line's
correction is below the rounding of z_r); every order of the schema builds; and the mixin that gives an
observer the differentiator's velocity (order 1 and up) passes the time and the reading on."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from ftc_mj.methods.observers import Levant
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.observers.levant import Differentiator, DifferentiatorGains, LevantVelocity
from ftc_mj.methods.observers.ndob import LevantNDOB
from ftc_mj.methods.primitives import scalar


def make(order: str, n_joints: int = 2, **gains) -> Levant:
    config = Levant.Config.model_validate({"order": order, "L": 4.0, **gains}, context={"n_joints": n_joints})
    return Levant(config, n_joints, 1e-3)


@pytest.mark.parametrize("order", ["1", "2", "3", "5"])
def test_reset_sets_position_velocity_and_zeros_the_higher_states(order):
    """The differentiator's own reset (a building block a plugin may use without an observer around it, whose
    reset would write z0 and z1 first), and the observer's."""
    gains = DifferentiatorGains.model_validate({"order": order, "L": 4.0}, context={"n_joints": 2})
    for differentiator in (Differentiator(gains, (2,), scalar(1e-3)), make(order).differentiator):
        for z in differentiator.z:
            z[:] = 7.0  # what a run leaves
        differentiator.reset(np.array([0.1, -0.2]), np.array([0.5, -1.5]))
        z = differentiator.z
        assert len(z) == int(order) + 1
        np.testing.assert_array_equal(z[0], [0.1, -0.2])
        np.testing.assert_array_equal(z[1], [0.5, -1.5])
        for higher in z[2:]:
            np.testing.assert_array_equal(higher, 0.0)
    observer = make(order)
    for z in observer.differentiator.z:
        z[:] = 7.0
    observer.reset(np.array([0.1, -0.2]), np.array([0.5, -1.5]))
    np.testing.assert_array_equal(observer.q_hat, [0.1, -0.2])
    np.testing.assert_array_equal(observer.qd_hat, [0.5, -1.5])
    for higher in observer.differentiator.z[2:]:
        np.testing.assert_array_equal(higher, 0.0)


def test_every_order_has_its_lambdas_and_gains():
    for order in range(1, 6):
        gains = DifferentiatorGains.model_validate({"order": order, "L": 1.0}, context={"n_joints": 1})
        assert len(gains.lambdas()) == order + 1
        assert len(make(str(order)).differentiator.gains) == order + 1


@pytest.mark.parametrize("order", ["1", "2"])
def test_the_top_line_takes_the_sign_of_its_own_error(order):
    """v_r = -k_r sign(z_r - v_(r-1)): with z_r = 1000, the lower states 0 and z0 - f = 1e-60 the lower lines'
    corrections are tiny but not zero, the last one below z_r's last bit: v_(r-1) = z_r and v_r = 0, not the
    sign of the lower error."""
    observer = make(order, n_joints=1)
    observer.reset(np.array([1e-60]), np.array([0.0]))
    r = observer.differentiator.order
    observer.differentiator.z[r][:] = 1000.0
    observer.update(0.0, np.array([0.0]), None)
    v = observer.differentiator.rates
    assert v[r - 1][0] == 1000.0
    assert v[r][0] == 0.0


class Recorder(Observer):
    """An observer on a measured velocity that records what its update receives."""

    name: ClassVar[str] = "recorder"
    Config: ClassVar[type[DifferentiatorGains]] = DifferentiatorGains

    def update(self, t, q_meas, model):
        self.seen = (t, q_meas.copy(), model)

    def advance(self, tau, model):
        pass


class LevantRecorder(LevantVelocity, Recorder):
    pass


def test_the_velocity_mixin_passes_time_reading_and_model_on():
    config = DifferentiatorGains.model_validate({"order": "1", "L": 2.0}, context={"n_joints": 2})
    observer = LevantRecorder(config, 2, 1e-3)
    observer.reset(np.array([0.1, 0.2]), np.array([0.0, 1.0]))
    model = object()
    observer.update(0.25, np.array([0.3, -0.1]), model)
    t, q_meas, seen_model = observer.seen
    assert t == 0.25 and seen_model is model
    np.testing.assert_array_equal(q_meas, [0.3, -0.1])
    assert observer.qd_hat is observer.differentiator.z[1]


def test_the_ndob_on_a_first_order_differentiator():
    config = LevantNDOB.Config.model_validate({"order": "1", "L": 2.0, "X": 0.01}, context={"n_joints": 2})
    observer = LevantNDOB(config, 2, 1e-3)
    observer.reset(np.array([0.1, 0.2]), np.array([0.5, 1.0]))
    np.testing.assert_array_equal(observer.qd_hat, [0.5, 1.0])


def test_a_differentiator_without_a_velocity_is_refused():
    """Order 0 cannot come from the schema (orders start at 1); a config built without validation gets the
    message."""
    config = DifferentiatorGains.model_construct(order="0", L=np.array([1.0]))
    with pytest.raises(ValueError, match="^the differentiator must estimate the velocity$"):
        LevantRecorder(config, 1, 1e-3)


@pytest.mark.parametrize("value", [2, "2", np.int64(2), np.uint8(2)])
def test_an_integer_order_is_the_choice(value):
    assert DifferentiatorGains.model_validate({"order": value, "L": 1.0}, context={"n_joints": 1}).order == "2"


@pytest.mark.parametrize("value", [True, 2.0, np.float64(2.0), None, [2], "two", 0, 6])
def test_other_orders_are_refused(value):
    with pytest.raises(ValueError, match="Input should be '1', '2', '3', '4' or '5'"):
        DifferentiatorGains.model_validate({"order": value, "L": 1.0}, context={"n_joints": 1})
