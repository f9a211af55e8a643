"""An extended state observer whose error poles are a real pole and a damped pair.

The third-order linear ESO on the measured position, with the nominal model as known dynamics:

    dx1_hat/dt = x2_hat + l1 x1~
    dx2_hat/dt = Psi(x_hat) + M(x1)^-1 u + z_hat + l2 x1~          x1~ = x1 - x1_hat
    dz_hat/dt  = l3 x1~

z_hat is the LUaF estimate. The error dynamics have the characteristic polynomial
s^3 + l1 s^2 + l2 s + l3 = (s + w)(s^2 + 2 zeta w s + w^2), so

    l1 = (1 + 2 zeta) w,   l2 = (1 + 2 zeta) w^2,   l3 = w^3.

zeta = 1 gives the triple pole of Gao's bandwidth parameterisation (the built-in ``eso``); zeta < 1 a faster,
less damped estimate.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers import Observer
from ftc_mj.robot.nominal import StepModel


class PoleESOConfig(GainConfig):
    """The error poles: bandwidth w [rad/s] and the damping zeta of the complex pair."""

    #: Bandwidth w of every error pole [rad/s], one number or one per joint.
    bandwidth: PositiveJoints
    #: Damping zeta of the complex pole pair (1: a triple real pole).
    damping: PositiveJoints = 1.0


class PoleESO(Observer):
    """Third-order ESO with the poles (s + w)(s^2 + 2 zeta w s + w^2)."""

    name: ClassVar[str] = "pole_eso"
    Config: ClassVar[type[PoleESOConfig]] = PoleESOConfig
    signal_names: ClassVar[frozenset[str] | None] = frozenset()

    def __init__(self, config: PoleESOConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        # The gains are (members, n) arrays (one value per member and joint): used as arrays, never as floats.
        w, zeta = config.bandwidth, config.damping
        self.l1 = (1.0 + 2.0 * zeta) * w
        self.l2 = (1.0 + 2.0 * zeta) * w * w
        self.l3 = w * w * w
        self._error = np.zeros(self.shape)  # allocated once: nothing is allocated per period

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        np.subtract(q_meas, self.q_hat, out=self._error)
        # The whole injection into the velocity equation: what a compensating controller cancels.
        self.injection[:] = self.luaf_hat + self.l2 * self._error

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        qdd_hat = model.psi_hat + model.command_acceleration(tau) + self.injection
        self.q_hat += self.dt * (self.qd_hat + self.l1 * self._error)
        self.qd_hat += self.dt * qdd_hat
        self.luaf_hat += self.dt * self.l3 * self._error
