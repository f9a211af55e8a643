"""Conventional SMC, eqs. (3.46)-(3.49), on the exact closed loop of closed_loop.py (exact estimates).

Bounds were measured first and set with a 2-3x margin; the measured value is written beside each.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from closed_loop import DT, Period, make, reaching, settled, simulate

from ftc_mj.methods.controllers import SMC

GAINS = dict(c=5.0, bound=0.5, mu=0.5)  # K = 1


def test_defaults_and_switching_gain():
    controller = make(SMC, 3, c=2.0, bound=[0.5, 0.0, 2.0], mu=0.01)  # Table 3.2: c = 2, mu = 0.01
    assert controller.compensation == "estimate"  # (3.48) compensates the TOSMO's integral estimate only
    np.testing.assert_array_equal(controller.switching_gain(), [0.51, 0.01, 2.01])


@pytest.mark.parametrize(
    "gains",
    [
        {"bound": 0.5, "mu": 0.01},  # c missing
        {"c": 2.0, "mu": 0.01},  # bound missing
        {"c": 2.0, "bound": 0.5},  # mu missing
        {**GAINS, "c": 0.0},  # c positive
        {**GAINS, "bound": -1.0},
        {**GAINS, "mu": 0.0},
        {**GAINS, "c": [1.0, 2.0]},  # wrong length for 3 joints
        {**GAINS, "compensation": "tosmo"},
        {**GAINS, "beta1": 1.0},  # unknown key
    ],
)
def test_config_errors_raise_validation_error(gains):
    with pytest.raises(ValidationError):
        SMC.Config.model_validate(gains, context={"n_joints": 3})


@pytest.mark.parametrize("compensation", ["injection", "estimate", "none"])
def test_one_period_by_hand(compensation):
    """s = e_dot + c e (3.46); tau = -M (Psi + c e_dot - xdd_d + u_c + (bound + mu) sign(s)) (3.47)-(3.49).
    The observer attribute the option does not read is NaN."""
    c = np.array([2.0, 3.0])
    controller = make(SMC, 2, c=list(c), bound=[0.5, 1.0], mu=0.25, compensation=compensation)
    period = Period(compensation, qd_hat=(-0.5, 0.7))  # e = [0.2, -0.1], e_dot = [-0.7, 0.4]
    s = period.e_dot + c * period.e
    assert np.sign(s).tolist() == [-1.0, 1.0]

    tau = period.compute(controller)
    np.testing.assert_allclose(controller.sliding, s, rtol=1e-14)
    np.testing.assert_allclose(tau, period.expected(c * period.e_dot, np.array([0.75, 1.25]), s), rtol=1e-13)


def test_reaching_law_and_tracking():
    run = simulate(make(SMC, **GAINS), T=3.0, e0=0.2, ed0=-0.5)  # s(0) = -0.5 + 5 * 0.2 = 0.5
    measured = reaching(run, 1.0)
    # Per period s moves by K dt towards 0: measured deviation 5.0e-6 (O(dt^2)); a u_eq without c e_dot would
    # be off by c e_dot dt ~ 1e-3.
    assert measured["deviation"] < 1.5e-5
    assert measured["t_reach"][0] == pytest.approx(0.5, abs=3 * DT)  # |s(0)| / K; measured 0.501 s
    assert measured["band_ratio"] < 1.05  # measured max |s| / (K dt) after reaching: 1.003
    # On s = 0, e decays at rate c to the band's |e| <= K dt / c = 2e-4. RMS from 2 s: measured e 3.1e-5 rad,
    # e_dot 5.6e-4 rad/s.
    rms = settled(run, 2.0)
    assert rms["e"] < 1e-4
    assert rms["e_dot"] < 1.5e-3
