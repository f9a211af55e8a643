"""The nonlinear disturbance observer (NDOB) of Chen, Ballance, Gawthrop and O'Reilly, "A nonlinear disturbance
observer for robotic manipulators", IEEE Trans. Industrial Electronics 47(4), 2000, eqs. (8)-(12).

For M(q) qdd + C(q, qd) qd + g(q) = tau + d (d a torque disturbance), the NDOB is

    d_hat = z + p(qd),   dz/dt = -L z + L (C qd + g - tau - p(qd)),   dp/dt = L M(q) qdd        (Chen 2000)

with the paper's choice L = X^-1 M(q)^-1, p = X^-1 qd, X constant and invertible (here diagonal, one entry per
joint: the gain ``X``). Then d(d_hat)/dt = X^-1 M^-1 (d - d_hat): the estimate follows the disturbance as a
first-order filter, in one joint of inertia m with the time constant X m; explicit Euler at the period keeps
that exactly in discrete time for a velocity measured exactly: d_hat(k+1) = d_hat(k) + dt/(X m) (d - d_hat(k)).
Chen et al.'s stability condition (Theorem 1) is X + X^T - X^T Mdot X > 0.

In the testbed's terms, C qd + g = -M Psi (eq. (5.2)), so with luaf_hat = M^-1 d_hat (the LUaF in acceleration
units, qdd = Psi + M^-1 tau + LUaF: d = M LUaF)

    luaf_hat = M(x1)^-1 (z + X^-1 qd),   dz/dt = -X^-1 (luaf_hat + Psi + M(x1)^-1 tau)

M at the measured position. The observer needs a velocity:

* ``ndob``: the tachometers. It passes the measured state on as ``q_hat``, ``qd_hat`` (so Psi is taken at the
  readings, as C qd + g is in the paper); needs ``robot.sensors: [position, velocity]``.
* ``ndob_levant``: the estimate of Levant's differentiator (:mod:`ftc_mj.methods.observers.levant`) on the
  encoders, whose gains it takes flat (``order``, ``L``, ``lambda0``..); ``q_hat``, ``qd_hat`` are the
  differentiator's z0, z1 and Psi is taken there.

``injection`` is the LUaF estimate: the NDOB has no velocity equation of its own, so what a controller may
compensate is the disturbance it estimates.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.observers.levant import DifferentiatorGains, LevantVelocity
from ftc_mj.robot.nominal import StepModel


class NDOBConfig(GainConfig):
    """X of Chen et al. 2000 (L = X^-1 M^-1, p = X^-1 qd), its diagonal per joint [s / (kg m^2)]: one joint of
    inertia m follows a disturbance with the time constant X m."""

    X: PositiveJoints


class LevantNDOBConfig(NDOBConfig, DifferentiatorGains):
    """X of the NDOB and the gains of the Levant differentiator that gives it the velocity."""


class NDOB(Observer):
    """Chen et al. 2000's NDOB on the measured velocity; LUaF estimate M^-1 d_hat."""

    name: ClassVar[str] = "ndob"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[NDOBConfig]] = NDOBConfig
    requires: ClassVar[frozenset[str]] = frozenset({"position", "velocity"})

    def __init__(self, config: NDOBConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.inverse_x = 1.0 / config.X  # X^-1, diagonal
        self._decay = -self.dt * self.inverse_x  # -dt X^-1: dz per period per unit of (luaf_hat + Psi + M^-1 tau)
        self._integral = np.zeros(self.shape)  # z
        self._disturbance = np.zeros(self.shape)  # d_hat = z + X^-1 qd
        self._rate = np.zeros(self.shape)

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        """z(0) = -X^-1 qd(0): d_hat(0) = 0."""
        super().reset(q_hat, qd_hat)
        np.multiply(self.inverse_x, qd_hat, out=self._integral)
        np.negative(self._integral, out=self._integral)

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        if qd_meas is None:  # the scenario loader refuses this; a direct caller gets a clear message
            raise ValueError("ndob needs measured velocities (ndob_levant differentiates the encoders)")
        self.q_hat[:] = q_meas
        self.qd_hat[:] = qd_meas

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        disturbance = np.multiply(self.inverse_x, self.qd_hat, out=self._disturbance)
        disturbance += self._integral
        self.luaf_hat[:] = model.solve_M(disturbance)
        self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        rate = np.add(model.psi_hat, model.command_acceleration(tau), out=self._rate)
        rate += self.luaf_hat
        rate *= self._decay
        self._integral += rate


class LevantNDOB(LevantVelocity, NDOB):
    """The NDOB on the velocity estimate of Levant's differentiator: position-only."""

    name: ClassVar[str] = "ndob_levant"
    Config: ClassVar[type[LevantNDOBConfig]] = LevantNDOBConfig
