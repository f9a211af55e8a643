"""Non-singular fast terminal sliding-mode control on an integral surface, Chapter 5, eqs. (5.14)-(5.27).

Surface (5.15), with e = x1 - x_d (5.3) and e_hat = x2_hat - xd_d (5.14):

    s_hat = e_hat + integral of A,   A = b1 |e|^g1 sign(e) + b2 |e_hat|^g2 sign(e_hat) + b3 e + b4 e^3

Control (5.25)-(5.27):  u = -M(x1) (u_eq + u_sw), u_sw = (Delta_delta + mu) sign(s_hat),

    u_eq = Psi(x) + [k2 |x1~|^(1/3) sign(x1~) + Gamma (dx1_hat/dt - x2_hat) + integral k3 sign(x1~)] + A - xdd_d

The printed law writes Psi(x), but no velocity is measured: we use Psi(x_hat), which is also what the proof's
(5.31) contains, so the bracket (the observer's whole injection) cancels exactly and ds_hat/dt = -K sign(s_hat).

``compensation: none`` gives the comparator "NFTSMC without compensation" (Appendix B, (4.43)-(4.45) form):
the switching gain ``bound + mu`` must then cover the whole LUaF. ``compensation: estimate`` compensates only
the LUaF estimate (the Appendix-D-type comparators).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.controllers.base import Compensation, SlidingModeController
from ftc_mj.gains import Exponent, GainConfig, NonNegativeJoints, PositiveJoints
from ftc_mj.observers.base import signed_power


class NFTSMCConfig(GainConfig):
    """Gains of (5.15)-(5.27). ``gamma2`` defaults to 2 gamma1 / (1 + gamma1) as (5.15) prescribes."""

    beta1: PositiveJoints
    beta2: PositiveJoints
    beta3: PositiveJoints
    beta4: PositiveJoints
    gamma1: Exponent
    gamma2: Exponent | None = None
    #: Delta_delta of (5.27): the bound the switching term must dominate.
    bound: NonNegativeJoints
    mu: PositiveJoints
    compensation: Compensation = "injection"

    @model_validator(mode="after")
    def _default_gamma2(self) -> "NFTSMCConfig":
        if self.gamma2 is None:
            object.__setattr__(self, "gamma2", 2 * self.gamma1 / (1 + self.gamma1))
        return self


class NFTSMC(SlidingModeController):
    """Observer-based NFTSMC of Chapter 5, eqs. (5.14)-(5.27)."""

    name: ClassVar[str] = "nftsmc"
    Config: ClassVar[type[NFTSMCConfig]] = NFTSMCConfig

    def __init__(self, config: NFTSMCConfig, n_joints: int, dt: float):
        super().__init__(config, n_joints, dt)
        self.compensation = config.compensation
        self._gain = config.bound + config.mu
        self._integral = np.zeros(n_joints)

    def reset(self) -> None:
        super().reset()
        self._integral[:] = 0.0

    def surface(self, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config
        a = (
            c.beta1 * signed_power(e, c.gamma1)
            + c.beta2 * signed_power(e_dot, c.gamma2)
            + c.beta3 * e
            + c.beta4 * e**3
        )
        self.sliding[:] = e_dot + self._integral
        self._integral += self.dt * a
        return a

    def switching_gain(self) -> np.ndarray:
        return self._gain
