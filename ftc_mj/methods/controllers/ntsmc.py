"""Non-singular terminal sliding-mode control, Chapter 3 Appendix B, eqs. (3.50)-(3.53).

    s = e_dot + b1 e + b2 exp(-lambda t) (e^T e)^(-alpha) e                                   (3.50)
    u = -M(x1) (u_eq + u_c + u_sw),  u_eq = Psi(x_hat) + b1 e_dot + b2 A - xdd_d               (3.52)
    A = d/dt [exp(-lambda t) (e^T e)^(-alpha) e]
      = exp(-lambda t) (e^T e)^(-alpha) [ -lambda e - 2 alpha (e^T e)^(-1) (e^T e_dot) e + e_dot ]

e^T e couples the joints (one norm over the arm). The terminal term is |e|^(1 - 2 alpha) in size: it vanishes
at e = 0 for alpha < 1/2, but A carries |e|^(-2 alpha) e_dot, which grows without bound as e -> 0; the
factor exp(-lambda t) is what makes the law usable, by fading the term out. At e = 0 exactly both are set
to 0 (their limit along the surface). (3.52) writes e_dot; without tachometers we use the observer's.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, Compensation, SlidingModeController
from ftc_mj.methods.gains import Exponent, PositiveFloat, PositiveJoints
from ftc_mj.methods.primitives import exp, power


class NTSMCConfig(BoundedSwitchingConfig):
    """beta1, beta2, lambda, alpha of (3.50) (Table 3.2: 1.5, 0.4, 0.7, 0.3), Delta_d and mu of (3.53)."""

    beta1: PositiveJoints
    beta2: PositiveJoints
    decay: PositiveFloat  # lambda
    alpha: Exponent
    compensation: Compensation = "estimate"


class NTSMC(SlidingModeController):
    """NTSMC with the time-decaying terminal term of (3.50)."""

    name: ClassVar[str] = "ntsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[NTSMCConfig]] = NTSMCConfig

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config
        squared = np.sum(e * e, axis=-1, keepdims=True)
        nonzero = squared > 0.0
        safe = np.where(nonzero, squared, 1.0)
        weight = np.where(nonzero, exp(-c.decay * t) * power(safe, -c.alpha), 0.0)
        inner = np.sum(e * e_dot, axis=-1, keepdims=True)
        a = weight * (-c.decay * e - 2.0 * c.alpha * (inner / safe) * e + e_dot)
        self.sliding[:] = e_dot + c.beta1 * e + c.beta2 * weight * e
        return c.beta1 * e_dot + c.beta2 * a
