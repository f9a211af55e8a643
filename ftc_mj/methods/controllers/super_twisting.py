r"""Super-twisting sliding-mode control on a linear surface: the field's second-order sliding-mode baseline.

Surface and control, in the frame of :mod:`.base` (:math:`e = x_1 - x_d`, :math:`\dot e` the controller's
velocity minus :math:`\dot x_d`):

.. math::

    s = \dot e + c e

    u = -M(x_1) \left(u_{eq} + u_c + u_{sw}\right), \quad u_{eq} = \Psi(\hat x) + c \dot e - \ddot x_d

    u_{sw} = k_1 |s|^{1/2} \operatorname{sign}(s) + z, \quad \dot z = k_2 \operatorname{sign}(s), \quad z(0) = 0

On the plant (5.2), :math:`\ddot q = \Psi + M^{-1} \tau + \Delta`, this gives the super-twisting algorithm

.. math::

    \dot s = -k_1 |s|^{1/2} \operatorname{sign}(s) + v, \quad \dot v = -k_2 \operatorname{sign}(s) + \dot\rho,
    \quad v = \rho - z, \quad \rho = \Delta - u_c

(Levant, "Sliding order and sliding accuracy in sliding mode control", Int. J. Control 58(6), 1993; Moreno
and Osorio, "Strict Lyapunov functions for the super-twisting algorithm", IEEE TAC 57(4), 2012), which reaches
:math:`s = \dot s = 0` in finite time for any :math:`|\dot\rho| \le L` when :math:`k_1`, :math:`k_2` are
large enough: the control is continuous (z absorbs :math:`\rho`, no chattering gain above the perturbation),
unlike :math:`u_{sw} = K \operatorname{sign}(s)`. Sampled with period T it keeps
:math:`|s| = O(T^2)` and :math:`|\dot s| = O(T)` (Levant 1993). In discrete time :math:`u_{sw}` takes this
period's :math:`z_k`, then :math:`z_{k+1} = z_k + T k_2 \operatorname{sign}(s_k)` (explicit Euler).

Gains: ``c`` and either ``L`` (the bound on the perturbation's derivative, :math:`|\dot\rho| \le L`) with
Levant's rule :math:`k_1 = 1.5 L^{1/2}`, :math:`k_2 = 1.1 L` (Levant, "Robust exact differentiation via sliding
mode technique", Automatica 34(3), 1998: :math:`\lambda = 1.5 C^{1/2}`, :math:`\alpha = 1.1 C` for the same
algorithm), or both ``k1`` and ``k2``. ``compensation`` as for the other laws, default ``none`` (z then
estimates the whole LUaF). z is recorded as the signal ``twisting_integral``.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import Compensation, Controller, SlidingModeController
from ftc_mj.methods.gains import PositiveJoints, SuperTwistingGains
from ftc_mj.methods.primitives import signed_power


class SuperTwistingConfig(SuperTwistingGains):
    r"""Slope ``c`` of :math:`s = \dot e + c e`; either ``L`` (:math:`k_1 = 1.5 L^{1/2}`, :math:`k_2 = 1.1 L`)
    or both ``k1``, ``k2``."""

    c: PositiveJoints
    compensation: Compensation = "none"

class SuperTwisting(SlidingModeController):
    r"""Super-twisting control (Levant 1993; Moreno and Osorio 2012) on :math:`s = \dot e + c e`:
    :math:`u_{sw} = k_1 |s|^{1/2} \operatorname{sign}(s) + \int k_2 \operatorname{sign}(s)\, dt`."""

    name: ClassVar[str] = "super_twisting"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"twisting_integral"})
    Config: ClassVar[type[SuperTwistingConfig]] = SuperTwistingConfig

    def __init__(self, config: SuperTwistingConfig, n_joints: int, dt: float, members: int | None = None):
        # The frame's own __init__ forms the switching gain bound + mu, which this law does not have.
        Controller.__init__(self, config, n_joints, dt, members)
        self.compensation: Compensation = config.compensation
        self._k1, self._k2 = config.gains()
        self._integral = np.zeros(self.shape)
        self._terms = np.zeros(self.shape)
        self._switching = np.zeros(self.shape)
        self._rate = np.zeros(self.shape)
        self.signals["twisting_integral"] = self._integral

    def reset(self) -> None:
        super().reset()
        self._integral[:] = 0.0

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config.c
        np.multiply(c, e, out=self.sliding)
        self.sliding += e_dot
        return np.multiply(c, e_dot, out=self._terms)

    def switching(self) -> np.ndarray:
        r""":math:`k_1 |s|^{1/2} \operatorname{sign}(s) + z_k` with this period's z; then
        :math:`z_{k+1} = z_k + T k_2 \operatorname{sign}(s_k)` (explicit Euler)."""
        s, u_sw = self.sliding, self._switching
        signed_power(s, 0.5, out=u_sw)
        u_sw *= self._k1
        u_sw += self._integral
        np.sign(s, out=self._rate)
        self._rate *= self._k2
        self._rate *= self.dt
        self._integral += self._rate
        return u_sw
