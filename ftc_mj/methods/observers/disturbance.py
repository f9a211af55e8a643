r"""Chapter 2's disturbance observer (DO), eq. (2.6), with its LUaF estimate (2.20). Needs tachometers.

With :math:`x_2` the measured velocity and :math:`\tilde x_2 = x_2 - \hat x_2`, (2.6) and (2.20):

.. math::

    \dot{\hat x}_2 = H(x) + D(x_1)^{-1} u + \hat\zeta

    \hat\zeta = k_1 |\tilde x_2|^{1/2} \operatorname{sign}(\tilde x_2) + p_1 \tilde x_2 + z

    \dot z = k_2 \operatorname{sign}(\tilde x_2) + p_2 \tilde x_2

a super-twisting observer on the velocity error with added linear terms (Remark 2.2: they speed up the
convergence far from the origin). :math:`\hat\zeta` contains the integral z, so it needs no filter (Remark
2.3). :math:`H(x)` is the nominal model's :math:`\Psi`, which holds its joint friction F where it has one
(:mod:`ftc_mj.robot.friction`): :math:`H = -D^{-1} (C x_2 + G + F)`, so F is subtracted there. (2.34), which
restates (2.26) for the adaptive law, prints :math:`z = k_2 \operatorname{sign}(\tilde x_2) + p_2 \tilde x_2`
without the dot; we use (2.6)'s :math:`\dot z`.

Chapter 2's controllers use measured states: this observer passes the tachometer and encoder readings on as
``q_hat`` and ``qd_hat`` (so :math:`\Psi` is :math:`H(x)` of the measured state and :math:`\dot e` the measured
error), keeps its own :math:`\hat x_2` internally, and offers :math:`\hat\zeta` as both the LUaF estimate and
the injection (:math:`u_c` of (2.26)).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import signed_power
from ftc_mj.robot.nominal import StepModel


class DisturbanceObserverConfig(GainConfig):
    """k1, k2, p1, p2 of (2.6) (Table 2.2: 8, 18, 10, 10)."""

    k1: PositiveJoints
    k2: PositiveJoints
    p1: PositiveJoints
    p2: PositiveJoints


class DisturbanceObserver(Observer):
    """DO (2.6) on measured velocities; LUaF estimate (2.20)."""

    name: ClassVar[str] = "do"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[DisturbanceObserverConfig]] = DisturbanceObserverConfig
    requires: ClassVar[frozenset[str]] = frozenset({"position", "velocity"})

    def __init__(self, config: DisturbanceObserverConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        #: :math:`\hat x_2` of (2.6), the observer's own velocity state.
        self.velocity_state = np.zeros(self.shape)
        self._integral = np.zeros(self.shape)  # z
        self._error = np.zeros(self.shape)  # x2~ of this period

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        super().reset(q_hat, qd_hat)
        self.velocity_state[:] = qd_hat
        self._integral[:] = 0.0

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        if qd_meas is None:  # the scenario loader refuses this; a direct caller gets a clear message
            raise ValueError("the DO of (2.6) needs measured velocities")
        self.q_hat[:] = q_meas
        self.qd_hat[:] = qd_meas

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        c = self.config
        np.subtract(self.qd_hat, self.velocity_state, out=self._error)
        self.luaf_hat[:] = c.k1 * signed_power(self._error, 0.5) + c.p1 * self._error + self._integral
        self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        c = self.config
        self.velocity_state += self.dt * (model.psi_hat + model.command_acceleration(tau) + self.luaf_hat)
        self._integral += self.dt * (c.k2 * np.sign(self._error) + c.p2 * self._error)
