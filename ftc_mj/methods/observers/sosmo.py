r"""Second-order sliding-mode observer (super-twisting), eq. (4.37), LUaF estimate (4.39) through a filter.

With :math:`\tilde x_1 = x_1 - \hat x_1`, (4.37) on the plant (5.2):

.. math::

    \dot{\hat x}_1 = \hat x_2 + k_1 |\tilde x_1|^{1/2} \operatorname{sign}(\tilde x_1)

    \dot{\hat x}_2 = \Psi(\hat x) + M(x_1)^{-1} u + k_2 \operatorname{sign}(\tilde x_1)

The LUaF is the equivalent output injection :math:`\hat\Delta = k_2 \operatorname{sign}(\tilde x_1)` (4.39); it is
discontinuous, so the estimate is that injection through a first-order low-pass filter whose time constant
:math:`T_f` the scenario sets (the dissertation gives none), discretised exactly at the period T with the
injection held:

.. math::

    \hat\Delta_{k+1} = \hat\Delta_k
    + \left(1 - e^{-T / T_f}\right) \left(k_2 \operatorname{sign}(\tilde x_{1,k}) - \hat\Delta_k\right)

The controller can compensate either the raw injection or the filtered estimate.

Gains: Appendix A prints :math:`k_1 = 2.12 L^{2/3}`, :math:`k_2 = 1.1 L`, which is dimensionally inconsistent
for a super-twisting observer (:math:`k_1` must scale as :math:`L^{1/2}`); we use Levant's
:math:`k_1 = 1.5 L^{1/2}`, :math:`k_2 = 1.1 L` unless ``k1`` and ``k2`` are given explicitly. L must bound the
perturbation of the error dynamics, i.e. the LUaF itself (it enters :math:`\dot{\tilde x}_2` directly, (4.38)),
not its rate: the scenarios take the measured :math:`\max |\Delta|` rounded up. The :math:`M(x_1)^{-1} u` term
uses the measured position, as in (5.6), for all Chapter 5 observers alike ((4.37) prints
:math:`g(\hat x, t) u`).
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
    r"""Gains of (4.37): ``L`` (Levant's rule) or both ``k1, k2``; the LUaF filter's time constant
    :math:`T_f` [s]."""

    filter_time_constant: PositiveFloat

class SOSMO(Observer):
    r"""Super-twisting observer, eq. (4.37); LUaF :math:`k_2 \operatorname{sign}(\tilde x_1)` of (4.39) through
    a first-order low-pass filter."""

    name: ClassVar[str] = "sosmo"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[SOSMOConfig]] = SOSMOConfig

    def __init__(self, config: SOSMOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.k1, self.k2 = config.gains()
        #: The LUaF filter's weight :math:`1 - e^{-T / T_f}`: the exact discretisation of
        #: :math:`\dot{\hat\Delta} = (k_2 \operatorname{sign}(\tilde x_1) - \hat\Delta) / T_f` over one period.
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
