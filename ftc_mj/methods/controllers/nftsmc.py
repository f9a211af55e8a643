r"""Non-singular fast terminal sliding-mode control on an integral surface: Chapters 2, 4 and 5.

Surface (2.22) = (5.15), with :math:`e = x_1 - x_d` and :math:`\hat e = \hat x_2 - \dot x_d` the observer's
velocity minus the reference's ((5.14); the measured one in Chapter 2, where the DO passes the tachometer
through):

.. math::

    \hat s = \hat e + \int_0^t A\, dt, \qquad
    A = \beta_1 |e|^{\gamma_1} \operatorname{sign}(e) + \beta_2 |\hat e|^{\gamma_2} \operatorname{sign}(\hat e)
    + \beta_3 e + \beta_4 e^3

with :math:`0 < \gamma_1 < 1` and :math:`\gamma_2 = 2 \gamma_1 / (1 + \gamma_1)` by default ((2.23), (4.12)).
(2.22) writes the gains :math:`\kappa_i` and the exponents :math:`\beta_i` (:math:`\kappa_i \to \beta_i`,
:math:`\beta_i \to \gamma_i` here); Chapter 4's surface (4.15) is the same with :math:`\beta_3 = \beta_4 = 0`
(:math:`\kappa_1 \to \beta_1`, :math:`\alpha_1 \to \gamma_1`, :math:`\kappa_2 \to \beta_2`,
:math:`\alpha_2 \to \gamma_2`). Control (2.24)-(2.27), (4.16)-(4.18), (5.25)-(5.27):

.. math::

    u = -M(x_1) \left(u_{eq} + u_c + u_{sw}\right), \quad u_{eq} = \Psi(\hat x) + A - \ddot x_d, \quad
    u_{sw} = (\Delta + \mu) \operatorname{sign}(\hat s)

(:math:`\Delta` the gain ``bound``: :math:`\Delta_\delta` of (5.27), K of (2.27), :math:`\Xi` of (4.18),
:math:`\Lambda` of (4.45)). In discrete time :math:`\hat s_k = \hat e_k + I_k`, then
:math:`I_{k+1} = I_k + T A_k` (explicit Euler). The compensation :math:`u_c` selects the variant:

* ``injection``: the observer's whole velocity-equation injection. With the TOSMO this is
  :math:`k_2 |\tilde x_1|^{1/3} \operatorname{sign}(\tilde x_1) + \int k_3 \operatorname{sign}(\tilde x_1)\, dt`,
  the observer's terms of (4.17) (which prints :math:`\lambda_3` for the TOSMO's :math:`\gamma_3`); with the
  high-speed TOSMO those of (5.26), the same plus :math:`\Gamma (\dot{\hat x}_1 - \hat x_2)`; with the SOSMO
  :math:`k_2 \operatorname{sign}(\tilde x_1)`, the :math:`u_c` of (4.53).
  :math:`\dot{\hat s} = -(\Delta + \mu) \operatorname{sign}(\hat s)` exactly, then.
* ``estimate``: only the LUaF estimate: :math:`\int k_3 \operatorname{sign}(\tilde x_1)\, dt` of (4.61)
  (Appendix D), the DO's :math:`\hat\zeta` of (2.26).
* ``none``: no compensation; the switching gain covers the whole LUaF ((2.27) comparator, Appendix B (4.45)).

(5.26) prints :math:`\Psi(x)`, which needs the velocity; we use :math:`\Psi(\hat x)`, which is what the proof's
(5.31) contains.

:class:`AdaptiveNFTSMC` replaces the fixed gain by :math:`\hat K + \mu` with :math:`\dot{\hat K} = \rho |\hat s|`
(2.36), or with the dead-zone law (2.43) that stops the drift once :math:`|\hat s| < \varepsilon`.
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
    r"""Gains of the surface (2.22)/(5.15): :math:`\beta_1, \ldots, \beta_4`, :math:`\gamma_1`, :math:`\gamma_2`;
    ``gamma2`` defaults to :math:`2 \gamma_1 / (1 + \gamma_1)`, as (2.23) prescribes. ``beta3``, ``beta4``
    default to 0, which is Chapter 4's surface (4.15)."""

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
    r"""Adds the bound the switching term must dominate: :math:`\Delta_\delta` of (5.27), K of (2.27),
    :math:`\Xi` of (4.18), :math:`\Lambda` of (4.45)."""

    bound: NonNegativeJoints


class NFTSMC(SlidingModeController):
    """Observer-based NFTSMC, eqs. (2.22)-(2.27), (4.15)-(4.18), (5.14)-(5.27)."""

    name: ClassVar[str] = "nftsmc"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[NFTSMCConfig]] = NFTSMCConfig

    def __init__(self, config: NFTSMCSurfaceConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        #: The integral of A in the surface (5.15), :math:`I = \int_0^t A\, dt`.
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
    r"""Gains of (2.32)-(2.36) and (2.43): adaptation gain :math:`\rho`, dead zone :math:`\varepsilon` (0 = the
    plain law (2.36)), and the initial switching-gain estimate :math:`\hat K(0)`."""

    rho: PositiveJoints
    dead_zone: NonNegativeFloat = 0.0
    initial_gain: NonNegativeJoints | None = None


class AdaptiveNFTSMC(NFTSMC):
    r"""A-NFTSMC, eqs. (2.32)-(2.36): :math:`u_{sw} = (\hat K + \mu) \operatorname{sign}(s)`,
    :math:`\dot{\hat K} = \rho |s|`; with ``dead_zone`` :math:`\varepsilon > 0` the drift-free law (2.43):

    .. math::

        \dot{\hat K} = \begin{cases} \rho |s|, & |s| \ge \varepsilon \\ 0, & \text{else} \end{cases}

    In discrete time the period's gain is :math:`\hat K_k + \mu`, then
    :math:`\hat K_{k+1} = \hat K_k + T \dot{\hat K}_k` (explicit Euler). :math:`\hat K` is recorded as the
    signal ``switching_gain`` (Fig. 2.8)."""

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
