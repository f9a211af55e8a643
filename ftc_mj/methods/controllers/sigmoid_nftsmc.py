"""Chapter 3's proposed law: NFTSMC on a sigmoid-blended surface with TOSMO compensation, eqs. (3.18),
(3.26)-(3.28), and its "after convergence" form (3.35)-(3.37).

Surface (3.18), with e = x1 - x_d and e_hat = x2_hat - xd_d:

    s = e_hat + a(e) e + b(e) |e|^alpha sign(e),
    a(e) = 2 k1 / (1 + exp(-m1 (|e| - phi))),   b(e) = 2 k2 / (1 + exp(m2 (|e| - phi))),
    phi = (k2 / k1)^(1 / (1 - alpha))

so the linear term dominates far from the origin and the terminal term near it (phi is where k1 |e| and
k2 |e|^alpha are equal). Control (3.26)-(3.28): u = -M(x1) (u_eq + u_c + u_sw), u_sw = (Delta_d + mu) sign(s),

    u_eq = Psi(x_hat) - xdd_d + e_hat d/de[a(e) e + b(e) |e|^alpha sign(e)]
    d/de[...] = a + 2 k1 m1 |e| E1 / (1 + E1)^2 + b alpha |e|^(alpha - 1) - 2 k2 m2 E2 / (1 + E2)^2 |e|^alpha,
    E1 = exp(-m1 (|e| - phi)), E2 = exp(m2 (|e| - phi)).

Misprint: (3.27) prints the second term as 2 k1 m1 sign(e) E1 / (1 + E1)^2, without the factor e that the
chain rule gives (d/de [a(e) e] = a + e a'(e), a'(e) = 2 k1 m1 sign(e) E1 / (1 + E1)^2); we use the
derivative, so that ds/dt = -K sign(s) holds exactly as (3.32) claims. (3.27) also writes e_dot, which is not
measured; we use e_hat, as the surface does.

``compensation: injection`` gives the proposed law (3.27): gamma2 |x1~|^(1/3) sign(x1~) + integral gamma3
sign(x1~), the TOSMO's whole injection. ``compensation: estimate`` drops the gamma2 term: the
after-convergence law (3.36).

The law as printed has a singular term: e_hat b(e) alpha |e|^(alpha - 1) in u_eq grows without bound as
e -> 0 (alpha = 0.6 < 1), however small e_hat is. In a sampled loop that has converged, e crosses 0 between
samples; a sample that lands very close to it (|e| about 1e-11 rad) gives a torque spike of tens of N m that
kicks s off the surface. It is a property of (3.27)/(3.36) themselves, not a numerical accident: the term is
recorded every period as the signal ``terminal_slope_term`` [rad/s^2] so that its size and frequency can be
measured (``studies/sigmoid_spikes.py``). At e = 0 exactly the factor is set to 0.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, SlidingModeController
from ftc_mj.methods.gains import Exponent, PositiveJoints
from ftc_mj.methods.primitives import exp, power


class SigmoidNFTSMCConfig(BoundedSwitchingConfig):
    """kappa1, kappa2, mu1, mu2, alpha of (3.18) (Table 3.2: mu1 = 1.2, mu2 = 1.4, alpha = 0.6; the kappas are
    not given), Delta_d and mu of (3.28)."""

    kappa1: PositiveJoints
    kappa2: PositiveJoints
    mu1: PositiveJoints
    mu2: PositiveJoints
    alpha: Exponent

    @model_validator(mode="after")
    def _finite_phi(self) -> "SigmoidNFTSMCConfig":
        if not np.all(np.isfinite(self.phi())):
            raise ValueError("phi = (kappa2 / kappa1)^(1 / (1 - alpha)) overflows; choose closer kappas")
        return self

    def phi(self) -> np.ndarray:
        """The crossover |e| of (3.18), where kappa1 |e| = kappa2 |e|^alpha."""
        with np.errstate(over="ignore"):
            return power(self.kappa2 / self.kappa1, 1.0 / (1.0 - self.alpha))


class SigmoidNFTSMC(SlidingModeController):
    """Chapter 3's NFTSMC-TOSMO law (3.26)-(3.28), or (3.35)-(3.37) with ``compensation: estimate``."""

    name: ClassVar[str] = "sigmoid_nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"terminal_slope_term"})
    Config: ClassVar[type[SigmoidNFTSMCConfig]] = SigmoidNFTSMCConfig

    def __init__(self, config: SigmoidNFTSMCConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.phi = config.phi()
        #: e_hat b(e) alpha |e|^(alpha - 1) of this period, the singular part of u_eq (see the module docstring).
        self.terminal_slope_term = np.zeros(self.shape)
        self.signals["terminal_slope_term"] = self.terminal_slope_term

    def reset(self) -> None:
        super().reset()
        self.terminal_slope_term[...] = 0.0

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config
        magnitude = np.abs(e)
        e1 = exp(-c.mu1 * (magnitude - self.phi))
        e2 = exp(np.minimum(c.mu2 * (magnitude - self.phi), 700.0))  # large |e|: b -> 0 without overflow
        a = 2.0 * c.kappa1 / (1.0 + e1)
        b = 2.0 * c.kappa2 / (1.0 + e2)
        terminal = power(magnitude, c.alpha)
        self.sliding[:] = e_dot + a * e + b * np.copysign(terminal, e)
        nonzero = magnitude > 0.0
        # |e|^(alpha - 1), set to 0 at e = 0 (unbounded there); computed on a safe copy to avoid 0^(negative).
        steep = np.where(nonzero, power(np.where(nonzero, magnitude, 1.0), c.alpha - 1.0), 0.0)
        singular = b * c.alpha * steep
        slope = (
            a
            + 2.0 * c.kappa1 * c.mu1 * magnitude * e1 / (1.0 + e1) ** 2
            + singular
            - 2.0 * c.kappa2 * c.mu2 * e2 / (1.0 + e2) ** 2 * terminal
        )
        np.multiply(e_dot, singular, out=self.terminal_slope_term)
        return e_dot * slope
