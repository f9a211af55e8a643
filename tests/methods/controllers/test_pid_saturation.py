"""The PID's saturation on both sides and its clamping anti-windup at the boundary of its rule: the integral
is held only while saturated *and* its increment pushes deeper (v e < 0); a saturated command whose error
pulls it back (v e > 0, however small) integrates."""

from __future__ import annotations

import numpy as np
from closed_loop import FakeObserver, fake_step

from ftc_mj.methods.controllers import PID

DT = 1e-3


def _pid(limit: float = 1.0) -> PID:
    config = PID.Config.model_validate({"kp": 1.0, "ki": 1.0, "kd": 0.0, "torque_limit": limit},
                                       context={"n_joints": 2})
    pid = PID(config, 2, DT)
    pid.reset()
    return pid


def _compute(pid: PID, e: np.ndarray) -> np.ndarray:
    zeros = np.zeros(2)
    return pid.compute(0.0, zeros, zeros, zeros, e, FakeObserver(2), fake_step(np.eye(2))).copy()


def test_both_limits():
    tau = _compute(_pid(), np.array([5.0, -5.0]))  # v = -(kp e) = -5 and +5
    np.testing.assert_array_equal(tau, [-1.0, 1.0])


def test_saturated_and_pulled_back_integrates_saturated_and_pushed_holds():
    pid = _pid()
    pid.integral[:] = [-10.0, 10.0]
    # Joint 1: v = -(0.05 - 10) = 9.95, saturated at +1, v e = 0.4975 > 0: pulled back, integrates.
    # Joint 2: v = -(0.05 + 10) = -10.05, saturated at -1, v e < 0: pushed deeper, held.
    tau = _compute(pid, np.array([0.05, 0.05]))
    np.testing.assert_array_equal(tau, [1.0, -1.0])
    np.testing.assert_array_equal(pid.integral, [-10.0 + DT * 0.05, 10.0])
