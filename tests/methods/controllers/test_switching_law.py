"""The frame of the sliding-mode laws: u_sw = K sign(s) with sign(0) = 0, K = bound + mu (mu alone for a law
whose configuration has no bound), the adaptive gain's dead zone (2.43) adapting on its edge |s| = epsilon,
and reset putting the sliding variable, the torque and the recorded terms back to zero (not NaN)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from ftc_mj.methods.controllers import SMC, AdaptiveNFTSMC, SigmoidNFTSMC
from ftc_mj.methods.controllers.base import SwitchingConfig
from ftc_mj.methods.gains import PositiveJoints

DT = 1e-3
SURFACE = dict(beta1=15.0, beta2=10.0, gamma1=0.5, mu=0.5)


class SlopeConfig(SwitchingConfig):
    """The SMC's slope without a ``bound``: a third-party law of the frame whose gain is mu alone."""

    c: PositiveJoints


class Unbounded(SMC):
    Config: ClassVar[type[SlopeConfig]] = SlopeConfig


def make(cls, n_joints: int = 3, **gains):
    return cls(cls.Config.model_validate(gains, context={"n_joints": n_joints}), n_joints, DT)


def test_the_switching_term_is_the_gain_times_the_sign_of_s():
    controller = make(SMC, c=2.0, bound=0.5, mu=[0.25, 0.5, 1.0])
    controller.sliding[:] = [0.0, 0.3, -2.0]
    np.testing.assert_array_equal(controller.switching(), [0.0, 1.0, -1.5])


def test_without_a_bound_the_gain_is_mu():
    controller = make(Unbounded, c=2.0, mu=[0.25, 0.5, 1.0])
    np.testing.assert_array_equal(controller.switching_gain(), [0.25, 0.5, 1.0])


def test_the_adaptive_gain_adapts_on_the_edge_of_the_dead_zone():
    """K_hat' = rho |s| while |s| >= epsilon: at |s| = epsilon it still adapts, below it does not."""
    controller = make(AdaptiveNFTSMC, **SURFACE, rho=2.0, dead_zone=0.125, initial_gain=1.0)
    controller.sliding[:] = [0.125, -0.125, 0.0625]
    np.testing.assert_array_equal(controller.switching_gain(), 1.5)  # this period's K_hat + mu
    np.testing.assert_array_equal(controller.gain_estimate, [1.0 + DT * 0.25, 1.0 + DT * 0.25, 1.0])


@pytest.mark.parametrize(("cls", "gains", "recorded"), [
    (SMC, dict(c=2.0, bound=0.5, mu=0.5), ()),
    (SigmoidNFTSMC, dict(kappa1=2.0, kappa2=1.5, mu1=1.2, mu2=1.4, alpha=0.6, bound=0.5, mu=0.5),
     ("terminal_slope_term",)),
])
def test_reset_zeros_the_sliding_variable_torque_and_recorded_terms(cls, gains, recorded):
    controller = make(cls, **gains)
    arrays = [controller.sliding, controller.tau, *(controller.signals[name] for name in recorded)]
    for array in arrays:
        array[...] = 7.0
    controller.reset()
    for array in arrays:
        np.testing.assert_array_equal(array, 0.0)
