r"""Third-order sliding-mode observers: TOSMO, eq. (3.11)/(4.4), and the high-speed TOSMO, eq. (5.6).

High-speed TOSMO (5.6), with :math:`\tilde x_1 = x_1 - \hat x_1`:

.. math::

    \dot{\hat x}_1 = k_1 |\tilde x_1|^{2/3} \operatorname{sign}(\tilde x_1) + \hat x_2 + \Gamma \tilde x_1

    \dot{\hat x}_2 = \Psi(\hat x) + M(x_1)^{-1} u + k_2 |\tilde x_1|^{1/3} \operatorname{sign}(\tilde x_1)
    + \Gamma (\dot{\hat x}_1 - \hat x_2) + \int k_3 \operatorname{sign}(\tilde x_1)\, dt

The printed second line ends in :math:`- \dot{\hat z}`; with :math:`\dot{\hat z} = -k_3 \operatorname{sign}(\tilde x_1)`
that would feed the *derivative* of :math:`\hat z` back, which contradicts the error dynamics (5.7) the proof
uses (they carry :math:`+\hat z`). We use :math:`-\hat z` as in (3.11), so the LUaF estimate is the integral of
:math:`k_3 \operatorname{sign}(\tilde x_1)`, eq. (5.13). With :math:`\Gamma = 0` the observer is the TOSMO
(3.11); its LUaF estimate is (3.15).

Gains follow Remark 5.3 (and Section 3.3.1): :math:`k_1 = 2 D^{1/3}`, :math:`k_2 = 2.12 D^{2/3}`,
:math:`k_3 = 1.1 D`, from the bound D on the LUaF's derivative, unless k1, k2, k3 are given explicitly.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.fast import laws
from ftc_mj.methods.gains import GainConfig, NonNegativeFloat, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import signed_power
from ftc_mj.robot.nominal import StepModel


class TOSMOConfig(GainConfig):
    r"""Gains of (3.11): either ``D`` (:math:`\bar\Delta` of Remark 5.3) or all of ``k1, k2, k3``."""

    D: PositiveJoints | None = None
    k1: PositiveJoints | None = None
    k2: PositiveJoints | None = None
    k3: PositiveJoints | None = None

    @model_validator(mode="after")
    def _gains_given(self) -> "TOSMOConfig":
        explicit = [k is not None for k in (self.k1, self.k2, self.k3)]
        if self.D is None and not all(explicit):
            raise ValueError("give D (Remark 5.3) or all of k1, k2, k3")
        if self.D is not None and any(explicit):
            raise ValueError("give either D or k1, k2, k3, not both")
        return self

    def gains(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r"""(``k1``, ``k2``, ``k3``), from Remark 5.3 when only ``D`` is given: :math:`k_1 = 2 D^{1/3}`,
        :math:`k_2 = 2.12 D^{2/3}`, :math:`k_3 = 1.1 D`."""
        if self.D is not None:
            return 2.0 * self.D ** (1 / 3), 2.12 * self.D ** (2 / 3), 1.1 * self.D
        return self.k1, self.k2, self.k3


class HighSpeedTOSMOConfig(TOSMOConfig):
    r"""Gains of (5.6): those of the TOSMO plus the linear gain :math:`\Gamma` (``gamma``)."""

    gamma: NonNegativeFloat


class TOSMO(Observer):
    r"""Third-order sliding-mode observer, eq. (3.11): (5.6) with :math:`\Gamma = 0`; LUaF estimate eq. (3.15),
    :math:`\hat\Delta = \int k_3 \operatorname{sign}(\tilde x_1)\, dt`."""

    name: ClassVar[str] = "tosmo"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[TOSMOConfig]] = TOSMOConfig

    def __init__(self, config: TOSMOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.k1, self.k2, self.k3 = config.gains()
        self._luaf_step = self.dt * self.k3  # dt k3: the LUaF estimate's change per period, times sign(x1~)
        self._error = np.zeros(self.shape)
        self._power = np.zeros(self.shape)
        self._sign = np.zeros(self.shape)
        self._q_hat_rate = np.zeros(self.shape)
        self._qdd_hat = np.zeros(self.shape)
        #: The law's accelerator (:mod:`ftc_mj.fast.laws`) registered for this class exactly, or None: the NumPy law.
        self.accelerator = laws.accelerator(self, self.k1, self.k2, self._luaf_step)

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        if self.accelerator is not None:
            self.accelerator.update(q_meas, model)
            return
        error = np.subtract(q_meas, self.q_hat, out=self._error)
        np.sign(error, out=self._sign)
        # dx1_hat/dt - x2_hat: k1 |x1~|^(2/3) sign(x1~) (+ Gamma x1~), reused in the second line of (5.6).
        position_correction = self._linear(self.k1 * signed_power(error, 2 / 3, out=self._power), error)
        np.add(self.qd_hat, position_correction, out=self._q_hat_rate)
        # The injection: k2 |x1~|^(1/3) sign(x1~) (+ Gamma (dx1_hat/dt - x2_hat)) + the LUaF estimate.
        velocity_correction = self._linear(self.k2 * signed_power(error, 1 / 3, out=self._power),
                                           position_correction)
        np.add(velocity_correction, self.luaf_hat, out=self.injection)

    def _linear(self, correction: np.ndarray, signal: np.ndarray) -> np.ndarray:
        """A correction with its linear term: none in the TOSMO (3.11)."""
        return correction

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        if self.accelerator is not None:
            self.accelerator.advance(tau, model)
            return
        qdd_hat = np.add(model.psi_hat, model.command_acceleration(tau), out=self._qdd_hat)
        qdd_hat += self.injection
        self.q_hat += self.dt * self._q_hat_rate
        self.qd_hat += self.dt * qdd_hat
        self.luaf_hat += self._luaf_step * self._sign


class HighSpeedTOSMO(TOSMO):
    r"""High-speed TOSMO, eq. (5.6): the TOSMO plus the linear terms :math:`\Gamma \tilde x_1` and
    :math:`\Gamma (\dot{\hat x}_1 - \hat x_2)`; LUaF estimate eq. (5.13)."""

    name: ClassVar[str] = "hs_tosmo"
    Config: ClassVar[type[HighSpeedTOSMOConfig]] = HighSpeedTOSMOConfig

    def __init__(self, config: HighSpeedTOSMOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.linear_gain = config.gamma  # Gamma of (5.6), (members, n)

    def _linear(self, correction: np.ndarray, signal: np.ndarray) -> np.ndarray:
        r"""The correction plus :math:`\Gamma` times ``signal``: :math:`\Gamma \tilde x_1` in the first line of
        (5.6), :math:`\Gamma (\dot{\hat x}_1 - \hat x_2)` in the second."""
        return correction + self.linear_gain * signal


laws.register(TOSMO, lambda method: laws.TOSMOLaw(method, linear=False))
laws.register(HighSpeedTOSMO, lambda method: laws.TOSMOLaw(method, linear=True)
              if type(method.config.gamma) is np.ndarray and method.config.gamma.shape == method.shape else None)
