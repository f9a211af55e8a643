r"""Levant's arbitrary-order robust exact differentiator (Levant, "Higher-order sliding modes, differentiation
and output-feedback control", Int. J. Control 76(9-10), 2003, eqs. (8)-(9)), per joint on the measured
position :math:`f = x_1`, explicit Euler at the control period.

Order r estimates :math:`f, \dot f, \ldots, f^{(r)}` by :math:`z_0, \ldots, z_r`, given the Lipschitz constant
L of :math:`f^{(r)}` (:math:`|f^{(r+1)}| \le L`):

.. math::

    \dot z_0 = v_0, \quad v_0 = -\lambda_r L^{1/(r+1)} |z_0 - f|^{r/(r+1)} \operatorname{sign}(z_0 - f) + z_1

    \dot z_i = v_i, \quad v_i = -\lambda_{r-i} L^{1/(r-i+1)} |z_i - v_{i-1}|^{(r-i)/(r-i+1)}
    \operatorname{sign}(z_i - v_{i-1}) + z_{i+1}, \qquad 0 < i < r

    \dot z_r = -\lambda_0 L \operatorname{sign}(z_r - v_{r-1})

with the coefficients :math:`\lambda_0, \ldots, \lambda_5 = 1.1, 1.5, 2, 3, 5, 8` of Levant 2003 (Section 3; the
same in Reichhalter, Koch and Jadlovska's tuning tables), each overridable. In exact arithmetic and without
noise the estimates are exact after a finite transient; with the measurement sampled at the period
:math:`T` they are exact to within :math:`\mu_i L T^{r+1-i}` (Levant 2003, Theorem 3), and with
measurement noise of size :math:`\varepsilon` to within :math:`\mu_i L^{i/(r+1)} \varepsilon^{(r+1-i)/(r+1)}`.

Discretisation (``discretisation``): ``euler`` (the default), :math:`z_i(k+1) = z_i(k) + T v_i(k)`. Explicit
Euler keeps the last estimate's accuracy, but on a polynomial :math:`z_i` lags :math:`f^{(i)}` by about
:math:`T f^{(i+1)} / 2` (the difference quotient of the previous line): for :math:`i < r` an
:math:`O(T)` error, not :math:`O(T^{r+1-i})`. ``taylor`` adds the Taylor terms of the higher states
(Livne and Levant, "Proper discretization of homogeneous differentiators", Automatica 50(8), 2014),

.. math::

    z_i(k+1) = z_i(k) + T v_i(k) + \sum_{l=2}^{r-i} \frac{T^l}{l!} z_{i+l}(k)

which is exact on a polynomial of degree r and restores the :math:`T^{r+1-i}` accuracy.

The differentiator is model-free: ``q_hat`` is :math:`z_0` and ``qd_hat`` is :math:`z_1`. With
``use_model: true`` (order :math:`r \ge 2`) :math:`z_2` is the acceleration estimate and the LUaF estimate is,
by the plant (5.2),

.. math::

    \hat\Delta_k = z_{2,k} - \left(\Psi(z_{0,k}, z_{1,k}) + M(x_1)^{-1} u_{k-1}\right)

with :math:`\Psi` at the differentiator's own estimate (the engine evaluates the nominal model at ``q_hat``,
``qd_hat``) and :math:`u_{k-1}` the command of the previous period: the one held while the acceleration that
:math:`z_2` estimates acted (the command of this period is not known when the controller reads the estimate).
Without the model the LUaF estimate is zero. ``injection`` is the LUaF estimate (zero without the model): the
differentiator has no velocity equation driven by a model, so the only thing a controller may meaningfully
compensate is the LUaF estimate itself.
"""

from __future__ import annotations

import math
import numbers
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import power, signed_power
from ftc_mj.robot.nominal import StepModel

#: :math:`\lambda_0, \ldots, \lambda_5` of Levant 2003 (recursive form), the default coefficients.
LEVANT_LAMBDAS: tuple[float, ...] = (1.1, 1.5, 2.0, 3.0, 5.0, 8.0)
#: The highest order the default coefficients cover.
MAX_ORDER = len(LEVANT_LAMBDAS) - 1


def _order_text(value: object) -> object:
    """An order written as an integer (``order: 2``, or a NumPy integer from a grid) is the choice "2" (a choice
    is one for every member); a bool is no order."""
    return str(value) if isinstance(value, numbers.Integral) and not isinstance(value, bool) else value


#: The differentiator's order, a choice (it sets the number of states, so it is the same for every member).
Order = Annotated[Literal["1", "2", "3", "4", "5"], BeforeValidator(_order_text)]


class DifferentiatorGains(GainConfig):
    """The differentiator's gains, shared by :class:`Levant` and the NDOB on its estimate
    (:class:`~ftc_mj.methods.observers.ndob.LevantNDOB`)."""

    #: Order r (1: the super-twisting differentiator; 2 and 3 the common choices for a position).
    order: Order = "2"
    #: Lipschitz constant of the r-th derivative of the position, per joint (:math:`|q^{(r+1)}| \le L`).
    L: PositiveJoints
    lambda0: PositiveJoints = Field(LEVANT_LAMBDAS[0], validate_default=True)
    lambda1: PositiveJoints = Field(LEVANT_LAMBDAS[1], validate_default=True)
    lambda2: PositiveJoints = Field(LEVANT_LAMBDAS[2], validate_default=True)
    lambda3: PositiveJoints = Field(LEVANT_LAMBDAS[3], validate_default=True)
    lambda4: PositiveJoints = Field(LEVANT_LAMBDAS[4], validate_default=True)
    lambda5: PositiveJoints = Field(LEVANT_LAMBDAS[5], validate_default=True)
    #: ``euler``: :math:`z_i \leftarrow z_i + T v_i`; ``taylor``: plus the Taylor terms of the higher states
    #: (Livne and Levant 2014).
    discretisation: Literal["euler", "taylor"] = "euler"

    def lambdas(self) -> list:
        r""":math:`\lambda_0, \ldots, \lambda_r` of this order."""
        return [getattr(self, f"lambda{i}") for i in range(int(self.order) + 1)]


class LevantConfig(DifferentiatorGains):
    """Gains of the differentiator, and whether it estimates the LUaF with the nominal model."""

    use_model: bool = False

    @model_validator(mode="after")
    def _acceleration_estimated(self) -> "LevantConfig":
        if self.use_model and int(self.order) < 2:
            raise ValueError("use_model needs order >= 2 (z2 estimates the acceleration)")
        return self


class Differentiator:
    r"""The law of Levant 2003, eqs. (8)-(9), on ``shape`` arrays: :math:`z_0, \ldots, z_r`, explicit Euler."""

    def __init__(self, gains: DifferentiatorGains, shape: tuple[int, ...], dt: np.ndarray):
        self.order = r = int(gains.order)
        self.dt = dt
        lambdas = gains.lambdas()
        # k_i = lambda_(r-i) L^(1/(r-i+1)), the gain of the i-th line; p_i = (r-i)/(r-i+1) its exponent.
        self.gains = [lambdas[r - i] * power(gains.L, 1.0 / (r - i + 1)) for i in range(r + 1)]
        self.exponents = [(r - i) / (r - i + 1) for i in range(r)]
        self.z = [np.zeros(shape) for _ in range(r + 1)]
        # Livne and Levant 2014: z_i += dt v_i + sum over l >= 2 of dt^l / l! z_(i+l); (i, coefficient, i + l).
        T = float(dt)
        self.taylor = [] if gains.discretisation == "euler" else [
            (i, T**l / math.factorial(l), i + l) for i in range(r + 1) for l in range(2, r - i + 1)]
        self.rates = [np.zeros(shape) for _ in range(r + 1)]  # v0..vr of this period
        self._error = np.zeros(shape)
        self._term = np.zeros(shape)

    def reset(self, position: np.ndarray, velocity: np.ndarray) -> None:
        self.z[0][:] = position
        if self.order >= 1:
            self.z[1][:] = velocity
        for z in self.z[2:]:
            z[:] = 0.0

    def update(self, f: np.ndarray) -> None:
        r"""The rates :math:`v_0, \ldots, v_r` for the measurement ``f``."""
        z, v, error, term = self.z, self.rates, self._error, self._term
        previous = f
        for i in range(self.order):
            np.subtract(z[i], previous, out=error)
            signed_power(error, self.exponents[i], out=term)
            np.multiply(self.gains[i], term, out=term)
            np.subtract(z[i + 1], term, out=v[i])
            previous = v[i]
        np.subtract(z[-1], previous, out=error)
        np.sign(error, out=term)
        np.multiply(self.gains[-1], term, out=v[-1])
        np.negative(v[-1], out=v[-1])

    def advance(self) -> None:
        r""":math:`z_i \leftarrow z_i + T v_i` (+ the Taylor terms: the higher states are read before they
        change)."""
        z, term = self.z, self._term
        for i, coefficient, higher in self.taylor:
            np.multiply(coefficient, z[higher], out=term)
            z[i] += term
        for state, v in zip(z, self.rates):
            np.multiply(self.dt, v, out=term)
            state += term


class LevantVelocity:
    """An observer built on a measured velocity, run instead on the velocity estimate of Levant's differentiator
    (position-only): mixed in before the observer's class (``class LevantNDOB(LevantVelocity, NDOB)``), whose
    ``Config`` must include :class:`DifferentiatorGains`. The differentiator's :math:`z_0` and :math:`z_1` are
    the observer's ``q_hat`` and ``qd_hat``; it takes the reading in ``update`` before the observer and steps
    after it."""

    requires: ClassVar[frozenset[str]] = frozenset({"position"})

    def __init__(self, config: DifferentiatorGains, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.differentiator = Differentiator(config, self.shape, self.dt)
        if self.differentiator.order < 1:  # pragma: no cover - the schema's orders start at 1
            raise ValueError("the differentiator must estimate the velocity")
        self.q_hat, self.qd_hat = self.differentiator.z[0], self.differentiator.z[1]

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        super().reset(q_hat, qd_hat)
        self.differentiator.reset(q_hat, qd_hat)

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        """The velocity is the differentiator's: nothing to read."""

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        self.differentiator.update(q_meas)
        super().update(t, q_meas, model)

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        super().advance(tau, model)
        self.differentiator.advance()


class Levant(Observer):
    r"""Levant's robust exact differentiator, Levant 2003 eqs. (8)-(9); with the nominal model its acceleration
    estimate gives the LUaF, :math:`\hat\Delta = z_2 - \Psi - M(x_1)^{-1} u` (see the module docstring)."""

    name: ClassVar[str] = "levant"
    signal_names: ClassVar[frozenset[str] | None] = frozenset()
    Config: ClassVar[type[LevantConfig]] = LevantConfig

    def __init__(self, config: LevantConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.differentiator = Differentiator(config, self.shape, self.dt)
        z = self.differentiator.z
        self.q_hat, self.qd_hat = z[0], z[1]  # the estimates are the differentiator's states themselves
        self.use_model = bool(config.use_model)
        self._command = np.zeros(self.shape)  # M(x1)^-1 u of the previous period

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        super().reset(q_hat, qd_hat)
        self.differentiator.reset(q_hat, qd_hat)
        self._command[:] = 0.0

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        self.differentiator.update(q_meas)
        if self.use_model:
            np.subtract(self.differentiator.z[2], model.psi_hat, out=self.luaf_hat)
            self.luaf_hat -= self._command
            self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        self.differentiator.advance()
        if self.use_model:
            self._command[:] = model.command_acceleration(tau)
