"""Conventional sliding-mode control: Chapter 2's comparator (Table 2.2) and Chapter 3 Appendix A, (3.46)-(3.49).

    s = e_dot + c e                                               (3.46)
    u = -M(x1) (u_eq + u_c + u_sw),  u_eq = Psi(x_hat) + c e_dot - xdd_d,  u_sw = (bound + mu) sign(s)

(3.48) compensates the TOSMO's LUaF estimate, integral gamma3 sign(x1~) (``compensation: estimate``);
Chapter 2's SMC has no observer compensation and a switching gain delta = 16 (``compensation: none``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, Compensation, SlidingModeController
from ftc_mj.methods.gains import PositiveJoints


class SMCConfig(BoundedSwitchingConfig):
    """Slope c of (3.46), the bound Delta_d (delta in Table 2.2) and mu of (3.49)."""

    c: PositiveJoints
    compensation: Compensation = "estimate"


class SMC(SlidingModeController):
    """Conventional SMC on the linear surface (3.46)."""

    name: ClassVar[str] = "smc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[SMCConfig]] = SMCConfig

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config.c
        self.sliding[:] = e_dot + c * e
        return c * e_dot
