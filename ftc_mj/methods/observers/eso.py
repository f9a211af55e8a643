r"""Linear extended state observer (ESO), the linear comparator of Chapter 2 (Fig. 2.3, "ESO [7]").

The dissertation does not print its ESO. We use the common third-order ESO on the measured position (so it
needs no tachometer and runs in every chapter), with the nominal model of (5.2) as known dynamics and Gao's
bandwidth parameterisation (Gao, "Scaling and bandwidth-parameterization based controller tuning", ACC 2003:
all three observer poles at :math:`-\omega_o`), with :math:`\tilde x_1 = x_1 - \hat x_1`:

.. math::

    \dot{\hat x}_1 = \hat x_2 + 3 \omega_o \tilde x_1

    \dot{\hat x}_2 = \Psi(\hat x) + M(x_1)^{-1} u + \hat z + 3 \omega_o^2 \tilde x_1

    \dot{\hat z} = \omega_o^3 \tilde x_1

:math:`\hat z` is the LUaF estimate (``luaf_hat``), and :math:`\hat z + 3 \omega_o^2 \tilde x_1` the injection.
The error dynamics are linear with characteristic polynomial :math:`(s + \omega_o)^3`, so the estimate
converges exponentially and fast for large :math:`\omega_o`, and overshoots during the transient, which is the
property Chapter 2 holds against it. Larger :math:`\omega_o` also passes more measurement noise. Explicit Euler
at the period, with :math:`\tilde x_1` of the period's measurement.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.nominal import StepModel


class ESOConfig(GainConfig):
    r"""Observer bandwidth :math:`\omega_o` [rad/s]: the gains are :math:`3 \omega_o`, :math:`3 \omega_o^2`,
    :math:`\omega_o^3`."""

    bandwidth: PositiveJoints


class ESO(Observer):
    r"""Third-order linear ESO with bandwidth parameterisation: its three poles at :math:`-\omega_o`."""

    name: ClassVar[str] = "eso"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[ESOConfig]] = ESOConfig

    def __init__(self, config: ESOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        w = config.bandwidth
        self.l1, self.l2, self.l3 = 3.0 * w, 3.0 * w**2, w**3
        self._error = np.zeros(self.shape)

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        np.subtract(q_meas, self.q_hat, out=self._error)
        self.injection[:] = self.luaf_hat + self.l2 * self._error

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        qdd_hat = model.psi_hat + model.command_acceleration(tau) + self.injection
        self.q_hat += self.dt * (self.qd_hat + self.l1 * self._error)
        self.qd_hat += self.dt * qdd_hat
        self.luaf_hat += self.dt * self.l3 * self._error
