r"""Chapter 3's proposed law: NFTSMC on a sigmoid-blended surface with TOSMO compensation, eqs. (3.18),
(3.26)-(3.28), and its "after convergence" form (3.35)-(3.37).

Surface (3.18), with :math:`e = x_1 - x_d` and :math:`\hat e = \hat x_2 - \dot x_d` ((3.16), (3.17)):

.. math::

    \hat s = \hat e + a(e)\, e + b(e)\, |e|^\alpha \operatorname{sign}(e), \qquad
    a(e) = \frac{2 \kappa_1}{1 + E_1}, \quad b(e) = \frac{2 \kappa_2}{1 + E_2}

    E_1 = \exp\left(-\mu_1 (|e| - \phi)\right), \quad E_2 = \exp\left(\mu_2 (|e| - \phi)\right), \quad
    \phi = (\kappa_2 / \kappa_1)^{1 / (1 - \alpha)}

so the linear term dominates far from the origin and the terminal term near it (:math:`\phi` is where
:math:`\kappa_1 |e|` and :math:`\kappa_2 |e|^\alpha` are equal, as defined below (3.18)). Control (3.26)-(3.28):
:math:`u = -M(x_1) (u_{eq} + u_c + u_{sw})`, :math:`u_{sw} = (\Delta_d + \mu) \operatorname{sign}(\hat s)`,

.. math::

    u_{eq} = \Psi(\hat x) - \ddot x_d + \hat e\, \frac{d}{de}\left[a(e)\, e + b(e)\, |e|^\alpha
    \operatorname{sign}(e)\right]

    \frac{d}{de}\left[\ldots\right] = a + \frac{2 \kappa_1 \mu_1 |e| E_1}{(1 + E_1)^2}
    + b \alpha |e|^{\alpha - 1} - \frac{2 \kappa_2 \mu_2 E_2}{(1 + E_2)^2} |e|^\alpha

Misprint: (3.27) prints the second term as
:math:`2 \kappa_1 \mu_1 \operatorname{sign}(e) E_1 / (1 + E_1)^2`, without the factor e that the chain rule
gives (:math:`\tfrac{d}{de}[a(e) e] = a + e\, a'(e)`,
:math:`a'(e) = 2 \kappa_1 \mu_1 \operatorname{sign}(e) E_1 / (1 + E_1)^2`); we use the derivative, so that
:math:`\dot{\hat s} = -(\Delta_d + \mu) \operatorname{sign}(\hat s)` holds exactly as (3.32) claims. (3.27) also
writes :math:`\dot e`, which is not measured; we use :math:`\hat e`, as the surface does.

``compensation: injection`` gives the proposed law (3.27), with the TOSMO's whole injection

.. math::

    u_c = \gamma_2 |\tilde x_1|^{1/3} \operatorname{sign}(\tilde x_1)
    + \int \gamma_3 \operatorname{sign}(\tilde x_1)\, dt

(the TOSMO (3.11) writes its gains :math:`\gamma_i`, ``k1, k2, k3`` in the scenarios).
``compensation: estimate`` drops the :math:`\gamma_2` term: the after-convergence law (3.36).

The law as printed has a singular term: :math:`\hat e\, b(e)\, \alpha |e|^{\alpha - 1}` in :math:`u_{eq}` grows
without bound as :math:`e \to 0` (:math:`\alpha = 0.6 < 1`), however small :math:`\hat e` is. In a sampled loop
that has converged, e crosses 0 between samples; a sample that lands very close to it (:math:`|e|` about
1e-11 rad) gives a torque spike of tens of N m that kicks :math:`\hat s` off the surface. It is a property of
(3.27)/(3.36) themselves, not a numerical accident: the term is recorded every period as the signal
``terminal_slope_term`` [rad/s^2] so that its size and frequency can be measured
(``studies/sigmoid_spikes.py``). At :math:`e = 0` exactly the factor is set to 0.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import model_validator

from ftc_mj.methods.controllers.base import BoundedSwitchingConfig, SlidingModeController
from ftc_mj.methods.gains import Exponent, PositiveJoints
from ftc_mj.methods.primitives import exp, power


class SigmoidNFTSMCConfig(BoundedSwitchingConfig):
    r""":math:`\kappa_1, \kappa_2, \mu_1, \mu_2, \alpha` of (3.18) (Table 3.2: :math:`\mu_1 = 1.2`,
    :math:`\mu_2 = 1.4`, :math:`\alpha = 0.6`; the :math:`\kappa` are not given), :math:`\Delta_d` (``bound``)
    and :math:`\mu` of (3.28)."""

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
        r"""The crossover :math:`\phi = (\kappa_2 / \kappa_1)^{1 / (1 - \alpha)}` of (3.18), the :math:`|e|` where
        :math:`\kappa_1 |e| = \kappa_2 |e|^\alpha`."""
        with np.errstate(over="ignore"):
            return power(self.kappa2 / self.kappa1, 1.0 / (1.0 - self.alpha))


class SigmoidNFTSMC(SlidingModeController):
    r"""Chapter 3's NFTSMC-TOSMO law (3.26)-(3.28) on the surface (3.18), or (3.35)-(3.37) with
    ``compensation: estimate``: :math:`u = -M(x_1) (u_{eq} + u_c + u_{sw})`."""

    name: ClassVar[str] = "sigmoid_nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"terminal_slope_term"})
    Config: ClassVar[type[SigmoidNFTSMCConfig]] = SigmoidNFTSMCConfig

    def __init__(self, config: SigmoidNFTSMCConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.phi = config.phi()
        #: :math:`\hat e\, b(e)\, \alpha |e|^{\alpha - 1}` of this period, the singular part of :math:`u_{eq}` (see
        #: the module docstring).
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
