"""Super-twisting sliding-mode control on a linear surface: the field's second-order sliding-mode baseline.

Surface and control, in the frame of :mod:`.base` (e = x1 - x_d, e_dot the controller's velocity minus xd_d):

    s = e_dot + c e
    u = -M(x1) (u_eq + u_c + u_sw),   u_eq = Psi(x_hat) + c e_dot - xdd_d,
    u_sw = k1 |s|^(1/2) sign(s) + z,   dz/dt = k2 sign(s),  z(0) = 0

On the plant qdd = Psi + M^-1 tau + LUaF (5.2) this gives the super-twisting algorithm

    ds/dt = -k1 |s|^(1/2) sign(s) + v,   dv/dt = -k2 sign(s) + d rho/dt,   v = rho - z,   rho = LUaF - u_c

(Levant, "Sliding order and sliding accuracy in sliding mode control", Int. J. Control 58(6), 1993; Moreno
and Osorio, "Strict Lyapunov functions for the super-twisting algorithm", IEEE TAC 57(4), 2012), which
reaches s = ds/dt = 0 in finite time for any |d rho/dt| <= L when k1, k2 are large enough: the control is
continuous (z absorbs rho, no chattering gain above the perturbation), unlike u_sw = K sign(s). Sampled with
period dt it keeps |s| = O(dt^2) and |ds/dt| = O(dt) (Levant 1993).

Gains: ``c`` and either ``L`` (the bound on the perturbation's derivative, |d rho/dt| <= L) with Levant's rule
k1 = 1.5 L^(1/2), k2 = 1.1 L (Levant, "Robust exact differentiation via sliding mode technique", Automatica
34(3), 1998: lambda = 1.5 C^(1/2), alpha = 1.1 C for the same algorithm), or both ``k1`` and ``k2``. ``compensation`` as for the
other laws, default ``none`` (z then estimates the whole LUaF). z is recorded as the signal
``twisting_integral``.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import Compensation, Controller, SlidingModeController
from ftc_mj.methods.gains import PositiveJoints, SuperTwistingGains
from ftc_mj.methods.primitives import signed_power


class SuperTwistingConfig(SuperTwistingGains):
    """Slope ``c`` of s = e_dot + c e; either ``L`` (k1 = 1.5 L^(1/2), k2 = 1.1 L) or both ``k1``, ``k2``."""

    c: PositiveJoints
    compensation: Compensation = "none"

class SuperTwisting(SlidingModeController):
    """Super-twisting control (Levant 1993; Moreno and Osorio 2012) on s = e_dot + c e."""

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
        """k1 |s|^(1/2) sign(s) + z with this period's z; then z += dt k2 sign(s) (explicit Euler)."""
        s, u_sw = self.sliding, self._switching
        signed_power(s, 0.5, out=u_sw)
        u_sw *= self._k1
        u_sw += self._integral
        np.sign(s, out=self._rate)
        self._rate *= self._k2
        self._rate *= self.dt
        self._integral += self._rate
        return u_sw
