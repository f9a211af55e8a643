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

from ftc_mj.methods import compiled
from ftc_mj.methods.compiled import entry, kernel
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
        self._integral = np.zeros(self.shape)
        c = self.config
        #: The fused law (:mod:`ftc_mj.methods.compiled`) and its buffers: e_dot, the bases |e|, |e_dot| and e
        #: (stacked), their powers |e|^g1, |e_dot|^g2 and e^3 (stacked), and -u.
        self._fused = compiled.fused(self, (NFTSMC,), c.beta1, c.beta2, c.beta3, c.beta4, c.gamma1, c.gamma2,
                                     self._gain)
        self._error_rate, self._negative_u = np.zeros(self.shape), np.zeros(self.shape)
        self._bases, self._powers = np.zeros((3, *self.shape)), np.zeros((3, *self.shape))
        self._magnitude, self._magnitude_rate, self._error = self._bases
        self._power, self._power_rate, self._cube = self._powers
        self._exponents = np.stack([np.broadcast_to(g, self.shape) for g in (c.gamma1, c.gamma2, 3.0)])
        self._find_errors = compiled.call_site(self, "_find_errors", _errors)
        self._find_negative_control = compiled.call_site(self, "_find_negative_control", _negative_control)
        self._period = float(dt)

    def reset(self) -> None:
        super().reset()
        self._integral[:] = 0.0

    def compute(self, t, q_ref, qd_ref, qdd_ref, q_meas, observer, model):
        if not self._fused:
            return super().compute(t, q_ref, qd_ref, qdd_ref, q_meas, observer, model)
        c, e, e_dot = self.config, self._error, self._error_rate
        self._find_errors(q_meas, q_ref, model.control_velocity(observer.qd_hat), qd_ref, e, e_dot, self._magnitude,
                          self._magnitude_rate)
        # The powers by NumPy, as signed_power and e**3 raise them, in one call: NumPy's pow per element (gains
        # of the state's shape), the same bits stacked as apart (tested), into other arrays than the bases.
        np.power(self._bases, self._exponents, self._powers)
        compensation = self.observer_compensation(observer)
        self._find_negative_control(e, e_dot, self._power, self._power_rate, self._cube, c.beta1, c.beta2, c.beta3,
                                    c.beta4, self._period, self._integral, self.sliding, qdd_ref, model.psi_control,
                                    e if compensation is None else compensation, compensation is not None,
                                    self._gain, self._negative_u)
        return model.apply_M(self._negative_u, out=self.tau)

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config
        a = (
            c.beta1 * signed_power(e, c.gamma1)
            + c.beta2 * signed_power(e_dot, c.gamma2)
            + c.beta3 * e
            + c.beta4 * e**3
        )
        np.add(e_dot, self._integral, out=self.sliding)
        self._integral += self.dt * a
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


@kernel
def _errors(q_meas, q_ref, velocity, qd_ref, e, e_dot, magnitude, magnitude_rate):  # noqa: ANN001, ANN202
    """e = x1 - x_d, e_dot = x2 - xd_d and their magnitudes (to be raised to gamma1, gamma2)."""
    for i in range(e.shape[0]):
        for j in range(e.shape[1]):
            error = q_meas[i, j] - entry(q_ref, i, j)
            error_rate = velocity[i, j] - entry(qd_ref, i, j)
            e[i, j], e_dot[i, j] = error, error_rate
            magnitude[i, j], magnitude_rate[i, j] = abs(error), abs(error_rate)


@kernel
def _negative_control(e, e_dot, power, power_rate, cube, beta1, beta2, beta3, beta4, dt,  # noqa: ANN001, ANN202
                      integral, sliding, qdd_ref, psi_control, compensation, compensate, gain, negative_u):
    """The surface (5.15) and -u = xdd_d - (Psi + A) - u_c - (bound + mu) sign(s) of (5.25)-(5.27), in the
    reference's order of operations."""
    for i in range(e.shape[0]):
        for j in range(e.shape[1]):
            a = (beta1[i, j] * np.copysign(power[i, j], e[i, j]) + beta2[i, j] * np.copysign(power_rate[i, j],
                                                                                             e_dot[i, j])
                 + beta3[i, j] * e[i, j] + beta4[i, j] * cube[i, j])
            s = e_dot[i, j] + integral[i, j]
            sliding[i, j] = s
            integral[i, j] += dt * a
            value = entry(qdd_ref, i, j) - (psi_control[i, j] + a)
            if compensate:
                value -= compensation[i, j]
            negative_u[i, j] = value - gain[i, j] * compiled.sign(s)
