"""Independent joint PID: the integrator removes a constant load's steady-state error, the command respects
the torque limit, and conditional integration keeps the integrator from winding up while saturated.

Plant: one joint m qdd = tau + tau_d with a constant load tau_d, integrated exactly over each period with the
torque held; the fake observer gives the true velocity. Set-point regulation, so every error left is the
law's. Measured values beside each bound.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from closed_loop import DT, MASS, FakeObserver, Period, fake_step, make
from controller_batch import assert_batch_equals_single

from ftc_mj.methods.controllers import PID

GAINS = dict(kp=50.0, ki=100.0, kd=15.0)  # m s^3 + kd s^2 + kp s + ki: stable (kd kp > m ki)
LIMIT = 15.0  # N m, above the load: the set point is reachable


def regulate(gains: dict, load: float, set_point: float, T: float) -> dict:
    """From rest at q = 0 to ``set_point`` under the load; (steps,) arrays of e, tau and the integral."""
    controller = make(PID, 1, **gains)
    observer, step = FakeObserver(1), fake_step(MASS * np.eye(1))
    q, v = np.zeros(1), np.zeros(1)
    ref, zero = np.full(1, set_point), np.zeros(1)
    steps = int(round(T / DT))
    out = {key: np.zeros(steps) for key in ("e", "tau", "integral")}
    for k in range(steps):
        observer.qd_hat[:] = v
        tau = controller.compute(k * DT, ref, zero, zero, q.copy(), observer, step)
        out["e"][k], out["tau"][k], out["integral"][k] = (q - ref)[0], tau[0], controller.integral[0]
        a = (tau + load) / MASS
        q, v = q + v * DT + 0.5 * a * DT * DT, v + a * DT
    return out


# --------------------------------------------------------------------------------------------------
# configuration and one period


def test_defaults():
    config = PID.Config.model_validate(GAINS, context={"n_joints": 3})
    assert config.torque_limit is None and config.anti_windup == "clamping"
    np.testing.assert_array_equal(config.kd, [15.0, 15.0, 15.0])
    assert PID.Config.model_validate({**GAINS, "ki": 0.0}).ki.tolist() == [0.0]  # a PD controller


@pytest.mark.parametrize("gains", [{"ki": 1.0, "kd": 1.0}, {**GAINS, "kp": 0.0}, {**GAINS, "ki": -1.0},
                                   {**GAINS, "torque_limit": 0.0}, {**GAINS, "torque_limit": [1.0, 2.0]},
                                   {**GAINS, "anti_windup": "back_calculation"}, {**GAINS, "compensation": "none"}])
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        PID.Config.model_validate(gains, context={"n_joints": 3})


def test_two_periods_by_hand_and_no_model():
    """tau = -(K_p e + K_i I + K_d e_dot) clipped, I += dt e; M, Psi and the observer's estimates unused
    (the fake step's M and Psi are NaN here)."""
    kp, ki, kd = np.array([4.0, 6.0]), np.array([20.0, 30.0]), np.array([1.0, 2.0])
    controller = make(PID, 2, kp=list(kp), ki=list(ki), kd=list(kd), torque_limit=[100.0, 0.5])
    period = Period("none")
    period.step = fake_step(np.full((2, 2), np.nan), psi_hat=[np.nan, np.nan])
    integral = np.zeros(2)
    for _ in range(2):
        v = -(kp * period.e + ki * integral + kd * period.e_dot)  # e = [0.2, -0.1], e_dot = [0.3, -0.1]
        tau = period.compute(controller)
        np.testing.assert_allclose(tau, [v[0], 0.5 if v[1] > 0.5 else v[1]], rtol=1e-14)
        # joint 2 saturates above (v2 about 0.8); e2 = -0.1 < 0 would drive it further: I2 holds
        integral = integral + DT * period.e * [1.0, 0.0 if v[1] > 0.5 else 1.0]
        np.testing.assert_allclose(controller.signals["integral"], integral, rtol=1e-14)
    assert not controller.sliding.any()


# --------------------------------------------------------------------------------------------------
# the defining properties


@pytest.mark.slow  # a closed-loop run of seconds
def test_integrator_removes_a_constant_loads_steady_state_error():
    """PD (K_i = 0) leaves e = tau_d / K_p = 0.2 rad; PID drives it to 0 (measured 5.7e-8 rad at 10 s)."""
    pd = regulate({**GAINS, "ki": 0.0}, load=10.0, set_point=0.0, T=10.0)
    pid = regulate(GAINS, load=10.0, set_point=0.0, T=10.0)
    assert pd["e"][-1] == pytest.approx(10.0 / GAINS["kp"], rel=1e-6)
    assert abs(pid["e"][-1]) < 1e-6
    assert pid["integral"][-1] == pytest.approx(10.0 / GAINS["ki"], rel=1e-5)  # K_i I holds the load


@pytest.mark.slow  # a closed-loop run of seconds
def test_torque_limit_and_anti_windup():
    """A 1 rad step against a 10 N m load with |tau| <= 15 N m: the command saturates for about half a second.
    The command never exceeds the limit; with clamping the integrator holds exactly while the command is
    saturated in the first approach (the error drives it further), without it winds up to 0.6 rad s and the
    overshoot is six times larger. Measured overshoot 0.133 rad (clamping) against 0.790 rad (none)."""
    runs = {aw: regulate({**GAINS, "torque_limit": LIMIT, "anti_windup": aw}, load=-10.0, set_point=1.0, T=15.0)
            for aw in ("clamping", "none")}
    for run in runs.values():
        assert np.abs(run["tau"]).max() <= LIMIT
        assert abs(run["e"][-1]) < 1e-6  # both recover the set point in the end
    clamped, wound = runs["clamping"], runs["none"]
    first = np.argmax(np.abs(clamped["tau"]) < LIMIT)  # the first saturated phase ends
    assert first > 300  # measured: saturated for 0.5 s
    assert not clamped["integral"][:first].any()  # as recorded after each period's update
    assert np.abs(wound["integral"]).max() > 3 * np.abs(clamped["integral"]).max()  # measured 0.60 against 0.17
    assert wound["e"].max() > 3 * clamped["e"].max()


def test_batch_equals_single_member_by_member():
    """5 members of a 3-joint law, each with its own gains and limits; small limits so that the clipping and
    the integrator's gate act."""
    members = [{"kp": 50.0 + m, "ki": [10.0, 0.0, 3.0 * m], "kd": 2.0 + m, "torque_limit": [0.5 + m, 3.0, 20.0]}
               for m in range(5)]
    assert_batch_equals_single(PID, members)
    assert_batch_equals_single(PID, [{**GAINS, "kp": 1.0 + m} for m in range(4)])  # no limit
