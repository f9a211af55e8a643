"""Linear extended state observer (ESO), the linear comparator of Chapter 2 (Fig. 2.3, "ESO [7]").

The dissertation does not print its ESO. We use the common third-order ESO on the measured position (so it
needs no tachometer and runs in every chapter), with the nominal model as known dynamics and Gao's bandwidth
parameterisation (all three observer poles at -omega_o):

    dx1_hat/dt = x2_hat + 3 omega_o x1~
    dx2_hat/dt = Psi(x_hat) + M(x1)^-1 u + z_hat + 3 omega_o^2 x1~           x1~ = x1 - x1_hat
    dz_hat/dt  = omega_o^3 x1~

z_hat is the LUaF estimate. The error dynamics are linear with characteristic polynomial (s + omega_o)^3, so
the estimate converges exponentially and fast for large omega_o, and overshoots during the transient, which
is the property Chapter 2 holds against it. Larger omega_o also passes more measurement noise.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.nominal import StepModel


class ESOConfig(GainConfig):
    """Observer bandwidth omega_o [rad/s]: the gains are 3 omega_o, 3 omega_o^2, omega_o^3."""

    bandwidth: PositiveJoints


class ESO(Observer):
    """Third-order linear ESO with bandwidth parameterisation."""

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
