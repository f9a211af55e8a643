r"""Conventional sliding-mode control: Chapter 2's comparator (Table 2.2) and Chapter 3 Appendix A, (3.46)-(3.49).

.. math::

    \hat s = \hat e + c e

    u = -M(x_1) \left(u_{eq} + u_c + u_{sw}\right), \quad u_{eq} = \Psi(\hat x) + c \hat e - \ddot x_d, \quad
    u_{sw} = (\Delta_d + \mu) \operatorname{sign}(\hat s)

with :math:`e = x_1 - x_d`, :math:`\hat e = \hat x_2 - \dot x_d`. (3.48) compensates the TOSMO's LUaF estimate,
:math:`u_c = \int \gamma_3 \operatorname{sign}(\tilde x_1)\, dt` (``compensation: estimate``), and writes
:math:`c \dot e` for :math:`c \hat e` (no tachometer: we use the observer's); Chapter 2's SMC has no observer
compensation and a switching gain :math:`\delta = 16` (``compensation: none``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, Compensation, SlidingModeController
from ftc_mj.methods.gains import PositiveJoints


class SMCConfig(BoundedSwitchingConfig):
    r"""Slope c of (3.46), the bound :math:`\Delta_d` (:math:`\delta` in Table 2.2) and :math:`\mu` of (3.49)."""

    c: PositiveJoints
    compensation: Compensation = "estimate"


class SMC(SlidingModeController):
    r"""Conventional SMC on the linear surface (3.46), :math:`\hat s = \hat e + c e`."""

    name: ClassVar[str] = "smc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[SMCConfig]] = SMCConfig

    def surface(self, t: float, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
        c = self.config.c
        self.sliding[:] = e_dot + c * e
        return c * e_dot
