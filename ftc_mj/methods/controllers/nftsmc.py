"""Non-singular fast terminal sliding-mode control on an integral surface: Chapters 2, 4 and 5.

Surface (2.22) = (5.15), with e = x1 - x_d and e_dot the observer's velocity minus xd_d ((5.14); the measured
one in Chapter 2, where the DO passes the tachometer through):

    s = e_dot + integral of A,   A = b1 |e|^g1 sign(e) + b2 |e_dot|^g2 sign(e_dot) + b3 e + b4 e^3

Chapter 4's surface (4.15) is the same with b3 = b4 = 0 (kappa1 -> beta1, alpha1 -> gamma1, kappa2 -> beta2,
alpha2 -> gamma2). Control (2.24)-(2.27), (4.16)-(4.18), (5.25)-(5.27):

    u = -M(x1) (u_eq + u_c + u_sw),  u_eq = Psi(x_hat) + A - xdd_d,  u_sw = (bound + mu) sign(s)

The compensation u_c selects the variant:

* ``injection``: the observer's whole velocity-equation injection. With the TOSMO this is
  k2 |x1~|^(1/3) sign(x1~) + integral k3 sign(x1~), the bracket of (4.17); with the high-speed TOSMO the
  bracket of (5.26); with the SOSMO k2 sign(x1~), the u_c of (4.53). ds/dt = -K sign(s) exactly, then.
* ``estimate``: only the LUaF estimate: integral k3 sign(x1~) of (4.61) (Appendix D), the DO's zeta_hat of
  (2.26).
* ``none``: no compensation; the switching gain covers the whole LUaF ((2.27) comparator, Appendix B (4.45)).

(5.26) prints Psi(x), which needs the velocity; we use Psi(x_hat), which is what the proof's (5.31) contains.

:class:`AdaptiveNFTSMC` replaces the fixed gain by K_hat + mu with K_hat' = rho |s| (2.36), or with the
dead-zone law (2.43) that stops the drift once |s| < epsilon.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.fast import laws
from ftc_mj.methods.controllers.base import SlidingModeController, SwitchingConfig
from ftc_mj.methods.gains import Exponent, NonNegativeFloat, NonNegativeJoints, PositiveJoints
from ftc_mj.methods.primitives import signed_power


class NFTSMCSurfaceConfig(SwitchingConfig):
    """Gains of the surface (2.22)/(5.15); ``gamma2`` defaults to 2 gamma1 / (1 + gamma1), as (2.23)
    prescribes. ``beta3``, ``beta4`` default to 0, which is Chapter 4's surface (4.15)."""

    beta1: PositiveJoints
    beta2: PositiveJoints
    beta3: NonNegativeJoints | None = None
    beta4: NonNegativeJoints | None = None
    gamma1: Exponent
    gamma2: Exponent | None = None

    @model_validator(mode="after")
    def _defaults(self) -> "NFTSMCSurfaceConfig":
        if self.gamma2 is None:
            object.__setattr__(self, "gamma2", 2 * self.gamma1 / (1 + self.gamma1))
        for name in ("beta3", "beta4"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.zeros_like(self.beta1))
        return self


class NFTSMCConfig(NFTSMCSurfaceConfig):
    """Adds the bound the switching term must dominate: Delta_delta of (5.27), K of (2.27), Xi of (4.18),
    Lambda of (4.45)."""

    bound: NonNegativeJoints


class NFTSMC(SlidingModeController):
    """Observer-based NFTSMC, eqs. (2.22)-(2.27), (4.15)-(4.18), (5.14)-(5.27)."""

    name: ClassVar[str] = "nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[NFTSMCConfig]] = NFTSMCConfig

    def __init__(self, config: NFTSMCSurfaceConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        #: The integral of A in the surface (5.15).
        self.integral = np.zeros(self.shape)
        c = self.config
        #: The law's accelerator (:mod:`ftc_mj.fast.laws`) registered for this class exactly, or None: the NumPy law.
        self.accelerator = laws.accelerator(self, c.beta1, c.beta2, c.beta3, c.beta4, c.gamma1, c.gamma2, self._gain)

    def reset(self) -> None:
        super().reset()
        self.integral[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        if self.accelerator is not None:
            return self.accelerator.compute(q_ref, qd_ref, qdd_ref, q_meas, observer, model)
        return super().compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config
        a = (
            c.beta1 * signed_power(e, c.gamma1)
            + c.beta2 * signed_power(e_dot, c.gamma2)
            + c.beta3 * e
            + c.beta4 * e**3
        )
        np.add(e_dot, self.integral, out=self.sliding)
        self.integral += self.dt * a
        return a


class AdaptiveNFTSMCConfig(NFTSMCSurfaceConfig):
    """Gains of (2.32)-(2.36) and (2.43): adaptation gain rho, dead zone epsilon (0 = the plain law (2.36)),
    and the initial switching-gain estimate K_hat(0)."""

    rho: PositiveJoints
    dead_zone: NonNegativeFloat = 0.0
    initial_gain: NonNegativeJoints | None = None


class AdaptiveNFTSMC(NFTSMC):
    """A-NFTSMC, eqs. (2.32)-(2.36): u_sw = (K_hat + mu) sign(s), K_hat' = rho |s|; with ``dead_zone`` > 0 the
    drift-free law (2.43): K_hat' = rho |s| only while |s| >= epsilon. K_hat is recorded as the signal
    ``switching_gain`` (Fig. 2.8)."""

    name: ClassVar[str] = "a_nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"switching_gain"})
    Config: ClassVar[type[AdaptiveNFTSMCConfig]] = AdaptiveNFTSMCConfig

    def __init__(self, config: AdaptiveNFTSMCConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        initial = 0.0 if config.initial_gain is None else config.initial_gain
        self._initial = np.broadcast_to(initial, self.shape).copy()
        self.gain_estimate = self._initial.copy()
        self._gain = np.zeros(self.shape)
        self.signals["switching_gain"] = self.gain_estimate

    def reset(self) -> None:
        super().reset()
        self.gain_estimate[...] = self._initial

    def switching_gain(self) -> np.ndarray:
        c = self.config
        np.add(self.gain_estimate, c.mu, out=self._gain)  # the gain of this period, then adapt (Euler)
        magnitude = np.abs(self.sliding)
        rate = c.rho * magnitude
        # (2.43): no adaptation inside the dead zone; with epsilon = 0 the plain law (2.36) (|s| >= 0 always).
        rate = np.where(magnitude >= c.dead_zone, rate, 0.0)
        self.gain_estimate += self.dt * rate
        return self._gain


laws.register(NFTSMC, laws.NFTSMCLaw)
