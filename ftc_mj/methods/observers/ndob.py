r"""The nonlinear disturbance observer (NDOB) of Chen, Ballance, Gawthrop and O'Reilly, "A nonlinear disturbance
observer for robotic manipulators", IEEE Trans. Industrial Electronics 47(4), 2000, eqs. (8)-(12).

For :math:`M(q)\ddot q + C(q, \dot q)\dot q + g(q) = \tau + d` (d a torque disturbance), the NDOB is

.. math::

    \hat d = z + p(\dot q), \quad \dot z = -L z + L \left(C \dot q + g - \tau - p(\dot q)\right), \quad
    \frac{d}{dt} p(\dot q) = L M(q) \ddot q

with the paper's choice :math:`L = X^{-1} M(q)^{-1}`, :math:`p = X^{-1} \dot q`, X constant and invertible
(here diagonal, one entry per joint: the gain ``X``). Then
:math:`\dot{\hat d} = X^{-1} M^{-1} (d - \hat d)`: the estimate follows the disturbance as a first-order filter,
in one joint of inertia m with the time constant X m; explicit Euler at the period T keeps that exactly in
discrete time for a velocity measured exactly: :math:`\hat d_{k+1} = \hat d_k + \tfrac{T}{X m} (d - \hat d_k)`.
Chen et al.'s stability condition (Theorem 1) is :math:`X + X^T - X^T \dot M X > 0`.

In the testbed's terms, :math:`C \dot q + g = -M \Psi` (eq. (5.2)), so with :math:`\hat\Delta = M^{-1} \hat d`
(``luaf_hat``, the LUaF in acceleration units: :math:`\ddot q = \Psi + M^{-1} \tau + \Delta`, so
:math:`d = M \Delta`)

.. math::

    \hat\Delta = M(x_1)^{-1} \left(z + X^{-1} \dot q\right), \quad
    \dot z = -X^{-1} \left(\hat\Delta + \Psi + M(x_1)^{-1} \tau\right), \quad z(0) = -X^{-1} \dot q(0)

M at the measured position, :math:`z(0)` so that :math:`\hat d(0) = 0`. The observer needs a velocity:

* ``ndob``: the tachometers. It passes the measured state on as ``q_hat``, ``qd_hat`` (so :math:`\Psi` is taken
  at the readings, as :math:`C \dot q + g` is in the paper); needs ``robot.sensors: [position, velocity]``.
* ``ndob_levant``: the estimate of Levant's differentiator (:mod:`ftc_mj.methods.observers.levant`) on the
  encoders, whose gains it takes flat (``order``, ``L``, ``lambda0``..); ``q_hat``, ``qd_hat`` are the
  differentiator's :math:`z_0`, :math:`z_1` and :math:`\Psi` is taken there.

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
    r"""X of Chen et al. 2000 (:math:`L = X^{-1} M^{-1}`, :math:`p = X^{-1} \dot q`), its diagonal per joint
    [s / (kg m^2)]: one joint of inertia m follows a disturbance with the time constant X m."""

    X: PositiveJoints


class LevantNDOBConfig(NDOBConfig, DifferentiatorGains):
    """X of the NDOB and the gains of the Levant differentiator that gives it the velocity."""


class NDOB(Observer):
    r"""Chen et al. 2000's NDOB, eqs. (8)-(12), on the measured velocity; LUaF estimate
    :math:`M(x_1)^{-1} \hat d`."""

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
        r""":math:`z(0) = -X^{-1} \dot q(0)`: :math:`\hat d(0) = 0`."""
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
