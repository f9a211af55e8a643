"""The plugin authors' check (ftc_mj.testing.assert_batch_equals_single): it passes the shipped methods, with
their accelerators and without, and fails a plugin whose member depends on the others or on the batch's size."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from ftc_mj import fast
from ftc_mj.methods.controllers import NFTSMC
from ftc_mj.methods.controllers.nftsmc import AdaptiveNFTSMC
from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers import SOSMO, HighSpeedTOSMO, TOSMO
from ftc_mj.methods.observers.base import Observer
from ftc_mj.testing import assert_batch_equals_single

SHIPPED = {
    TOSMO: [dict(D=22.0), dict(D=10.0), dict(D=0.5),
            dict(D=5.0), dict(D=40.0)],
    HighSpeedTOSMO: [dict(D=22.0, gamma=5.0), dict(D=10.0, gamma=0.0), dict(D=30.0, gamma=2.0), dict(D=1.0, gamma=9.0)],
    SOSMO: [dict(L=22.0, filter_time_constant=0.01), dict(L=5.0, filter_time_constant=0.002)],
    NFTSMC: [dict(beta1=15.0, beta2=10.0, beta3=10.0, beta4=5.0, gamma1=0.5, bound=0.5, mu=0.5),
             dict(beta1=5.0, beta2=3.0, beta3=1.0, beta4=0.0, gamma1=0.6, bound=[1.0, 2.0, 3.0], mu=0.1)],
    AdaptiveNFTSMC: [dict(beta1=15.0, beta2=10.0, gamma1=0.5, rho=2.0, mu=0.5, dead_zone=0.01),
                     dict(beta1=5.0, beta2=3.0, gamma1=0.7, rho=1.0, mu=0.1, dead_zone=0.01)],
}


@pytest.mark.parametrize("accelerated", [True, False], ids=["fast", "numpy"])
@pytest.mark.parametrize("plugin", list(SHIPPED), ids=lambda plugin: plugin.name)
def test_the_shipped_laws_pass(plugin, accelerated: bool) -> None:
    with fast.switched(accelerated):
        assert_batch_equals_single(plugin, SHIPPED[plugin], periods=60)


class MeanGainConfig(GainConfig):
    gain: PositiveJoints


class MeanGainObserver(Observer):
    """Batch-unsafe on purpose: every member's correction uses the batch's mean gain."""

    name: ClassVar[str] = "mean_gain"
    Config: ClassVar[type[MeanGainConfig]] = MeanGainConfig

    def update(self, t, q_meas, model):
        self.injection[:] = self.config.gain.mean() * (q_meas - self.q_hat)

    def advance(self, tau, model):
        self.q_hat += self.dt * self.qd_hat
        self.qd_hat += self.dt * (model.psi_hat + model.command_acceleration(tau) + self.injection)


class PythonPowerObserver(MeanGainObserver):
    """Batch-unsafe on purpose: the exponent 0.5 as a column per member (NumPy takes sqrt alone, pow in a batch)."""

    name: ClassVar[str] = "python_power"

    def update(self, t, q_meas, model):
        exponent = np.full((len(q_meas), 1), 0.5)
        self.injection[:] = self.config.gain * np.abs(q_meas - self.q_hat) ** exponent


def test_a_plugin_that_mixes_its_members_fails() -> None:
    with pytest.raises(AssertionError, match="injection, member 0, after update of period 0"):
        assert_batch_equals_single(MeanGainObserver, [dict(gain=1.0), dict(gain=2.0)])


def test_a_plugin_whose_kernel_depends_on_the_batch_size_fails() -> None:
    with pytest.raises(AssertionError, match="injection, member"):
        assert_batch_equals_single(PythonPowerObserver, [dict(gain=1.0), dict(gain=2.0), dict(gain=3.0)])


def test_one_member_is_refused() -> None:
    with pytest.raises(ValueError, match="two members"):
        assert_batch_equals_single(TOSMO, [dict(D=1.0)])
