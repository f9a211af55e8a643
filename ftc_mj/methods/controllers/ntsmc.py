r"""Non-singular terminal sliding-mode control, Chapter 3 Appendix B, eqs. (3.50)-(3.53).

With :math:`e = x_1 - x_d` and :math:`\hat e = \hat x_2 - \dot x_d` ((3.16), (3.17)), the surface (3.50) and
the control (3.51)-(3.53):

.. math::

    \hat s = \hat e + \beta_1 e + \beta_2 \exp(-\lambda t) (e^T e)^{-\alpha} e

    u = -M(x_1) \left(u_{eq} + u_c + u_{sw}\right), \quad
    u_{eq} = \Psi(\hat x) + \beta_1 \hat e + \beta_2 A - \ddot x_d, \quad
    u_{sw} = (\Delta_d + \mu) \operatorname{sign}(\hat s)

    A = \frac{d}{dt}\left[\exp(-\lambda t) (e^T e)^{-\alpha} e\right]
    = \exp(-\lambda t) (e^T e)^{-\alpha} \left[-\lambda e - 2 \alpha (e^T e)^{-1} (e^T \hat e)\, e + \hat e\right]

(A as the text after (3.53) prints it; :math:`u_c` defaults to the estimate of (3.52),
:math:`\int \gamma_3 \operatorname{sign}(\tilde x_1)\, dt`: ``compensation: estimate``). :math:`e^T e`
couples the joints (one norm over the arm). The terminal term is :math:`\|e\|^{1 - 2\alpha}` in size: it
vanishes at :math:`e = 0` for :math:`\alpha < 1/2`, but A carries :math:`\|e\|^{-2\alpha} \hat e`, which grows
without bound as :math:`e \to 0`; the factor :math:`\exp(-\lambda t)` is what makes the law usable, by fading
the term out. At :math:`e = 0` exactly both are set to 0 (their limit along the surface). (3.52) writes
:math:`\dot e`; without tachometers we use the observer's :math:`\hat e`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, Compensation, SlidingModeController
from ftc_mj.methods.gains import Exponent, PositiveFloat, PositiveJoints
from ftc_mj.methods.primitives import exp, power


class NTSMCConfig(BoundedSwitchingConfig):
    r""":math:`\beta_1, \beta_2, \lambda, \alpha` of (3.50) (Table 3.2: 1.5, 0.4, 0.7, 0.3; :math:`\lambda` is
    ``decay``), :math:`\Delta_d` (``bound``) and :math:`\mu` of (3.53)."""

    beta1: PositiveJoints
    beta2: PositiveJoints
    decay: PositiveFloat  # lambda
    alpha: Exponent
    compensation: Compensation = "estimate"


class NTSMC(SlidingModeController):
    r"""NTSMC with the time-decaying terminal term :math:`\beta_2 \exp(-\lambda t) (e^T e)^{-\alpha} e` of
    (3.50)."""

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
