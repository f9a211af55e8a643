"""Second-order sliding-mode observer (super-twisting), eq. (4.37), LUaF estimate (4.39) through a filter.

    dx1_hat/dt = x2_hat + k1 |x1_tilde|^(1/2) sign(x1_tilde)
    dx2_hat/dt = Psi(x_hat) + M(x1)^-1 u + k2 sign(x1_tilde)

The LUaF is the equivalent output injection k2 sign(x1_tilde) (4.39); it is discontinuous, so the estimate
is that injection through a first-order low-pass filter whose time constant the scenario sets (the
dissertation gives none). The controller can compensate either the raw injection or the filtered estimate.

Gains: Appendix A prints k1 = 2.12 L^(2/3), k2 = 1.1 L, which is dimensionally inconsistent for a
super-twisting observer (k1 must scale as L^(1/2)); we use Levant's k1 = 1.5 L^(1/2), k2 = 1.1 L unless k1 and
k2 are given explicitly. L must bound the perturbation of the error dynamics, i.e. the LUaF itself (it enters
dx2_tilde/dt directly), not its rate: the scenarios take the measured max |LUaF| rounded up. The M(x1)^-1 u term uses the measured position, as in (5.6), for all Chapter 5
observers alike.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.fast import laws
from ftc_mj.methods.gains import PositiveFloat, SuperTwistingGains
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import exp, signed_power
from ftc_mj.robot.nominal import StepModel


class SOSMOConfig(SuperTwistingGains):
    """Gains of (4.37): ``L`` (Levant's rule) or both ``k1, k2``; the LUaF filter's time constant [s]."""

    filter_time_constant: PositiveFloat

class SOSMO(Observer):
    """Super-twisting observer, eq. (4.37); LUaF from (4.39) through a first-order low-pass filter."""

    name: ClassVar[str] = "sosmo"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[SOSMOConfig]] = SOSMOConfig

    def __init__(self, config: SOSMOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.k1, self.k2 = config.gains()
        #: The LUaF filter's weight: the exact discretisation of d(luaf)/dt = (injection - luaf) / T over one period.
        self.filter_weight = 1.0 - exp(-self.dt / config.filter_time_constant)
        self._q_hat_rate = np.zeros(self.shape)
        #: The law's accelerator (:mod:`ftc_mj.fast.laws`) registered for this class exactly, or None: the NumPy law.
        self.accelerator = laws.accelerator(self, self.k1, self.k2, self.filter_weight)

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        if self.accelerator is not None:
            self.accelerator.update(q_meas, model)
            return
        error = q_meas - self.q_hat
        self._q_hat_rate[:] = self.qd_hat + self.k1 * signed_power(error, 0.5)
        self.injection[:] = self.k2 * np.sign(error)

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        if self.accelerator is not None:
            self.accelerator.advance(tau, model)
            return
        qdd_hat = model.psi_hat + model.command_acceleration(tau) + self.injection
        self.q_hat += self.dt * self._q_hat_rate
        self.qd_hat += self.dt * qdd_hat
        self.luaf_hat += self.filter_weight * (self.injection - self.luaf_hat)


laws.register(SOSMO, laws.SOSMOLaw)
