r"""The generalized momentum observer (De Luca and Mattone, "Sensorless robot collision detection and hybrid
force/motion control", ICRA 2005; Haddadin, De Luca and Albu-Schaeffer, "Robot collisions: a survey on
detection, isolation, and identification", IEEE T-RO 33(6), 2017, its momentum-based residual).

For :math:`M(q)\ddot q + C(q, \dot q)\dot q + G(q) + F(\dot q) = \tau + \tau_f` (:math:`\tau_f` a fault or
external torque, F the nominal model's joint friction, :mod:`ftc_mj.robot.friction`, zero where it has none),
the generalized momentum :math:`p = M(q)\dot q` obeys
:math:`\dot p = \tau + \tau_f + C^T(q, \dot q)\dot q - G(q) - F(\dot q)` (from :math:`\dot M = C + C^T`), and
the residual

.. math::

    r(t) = K_I \left(p(t) - p(0) - \int_0^t \left(\tau + C^T \dot q - G - F + r\right) ds\right)

follows the fault torque as a first-order filter per joint, :math:`\dot r = K_I (\tau_f - r)`: :math:`r_j`
tracks a step of :math:`\tau_{f,j}` with the time constant :math:`1 / K_{I,j}`, decoupled from the other
joints, with no acceleration measured and no :math:`M^{-1}` in the loop. :math:`K_I` (the gain ``K``, 1/s) is
diagonal.

**Discrete time.** At the control period T, with the state :math:`z = p(0) + \int` (z starts at the first p):

.. math::

    r_k = K_I (p_k - z_k)

    z_{k+1} = z_k + T (\tau_k + r_k) + \tfrac{T}{2} (C^T \dot q - G - F)_k + \tfrac{T}{2} (C^T \dot q - G - F)_{k+1}

the command by the rectangle rule (it is held over the period, so that is exact), the residual by explicit
Euler (the filter's own discretisation), and the model terms, smooth functions of the sampled state, by the
trapezoidal rule: their second half is added at the next sample, in :meth:`update`, before r is formed
(explicit Euler on them would leave :math:`\tfrac{T}{2} |\tfrac{d}{dt}(G - C^T \dot q)|`, 0.06 N m on the
PUMA560 at 3 rad/s). With the
velocity measured exactly, r then follows a step of the fault torque as
:math:`r_k = \tau_f \left(1 - (1 - K_I T)^k\right)`, within :math:`K_I T / (2e)` of the step of the continuous
filter.

**What the testbed hands it.** ``M`` at the measured position, and :math:`C^T \dot q` and G at the
observer's estimate (the nominal model's ``coriolis_transpose`` and ``gravity``, which the engine evaluates for
an observer that declares them in :attr:`needs`; MuJoCo gives only :math:`C \dot q + G`), and F at the same
point (its ``friction``). The residual r, a torque, is the signal ``residual``; the LUaF estimate is the
residual in the testbed's acceleration units, ``luaf_hat`` :math:`= M(x_1)^{-1} r` (on the plant (5.2),
:math:`\ddot q = \Psi + M^{-1} \tau + \Delta`, so :math:`\tau_f = M \Delta`), and so is ``injection``: the
observer has no velocity equation of its own a controller could cancel beyond its estimate.

The velocity in p and in :math:`C^T \dot q` is a choice:

* ``momentum``: the tachometers (the observer's classic setting); ``q_hat``, ``qd_hat`` are the readings, so
  :math:`C^T \dot q` and G are taken at the measured state. Needs ``robot.sensors: [position, velocity]``.
* ``momentum_levant``: the estimate of Levant's differentiator (:mod:`ftc_mj.methods.observers.levant`) on the
  encoders, whose gains it takes flat (``order``, ``L``, ``lambda0``..); ``q_hat``, ``qd_hat`` are its
  :math:`z_0`, :math:`z_1`: position-only.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.observers.levant import DifferentiatorGains, LevantVelocity
from ftc_mj.methods.primitives import scalar
from ftc_mj.robot.nominal import StepModel


class MomentumConfig(GainConfig):
    r""":math:`K_I` of the momentum observer, per joint [1/s]: the residual's bandwidth (its time constant
    :math:`1 / K_I`)."""

    K: PositiveJoints


class LevantMomentumConfig(MomentumConfig, DifferentiatorGains):
    r""":math:`K_I` of the momentum observer and the gains of the Levant differentiator that gives it the
    velocity."""


class MomentumObserver(Observer):
    r"""De Luca and Mattone's generalized momentum observer on the measured velocity; LUaF estimate
    :math:`M(x_1)^{-1} r`."""

    name: ClassVar[str] = "momentum"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"residual"})
    Config: ClassVar[type[MomentumConfig]] = MomentumConfig
    requires: ClassVar[frozenset[str]] = frozenset({"position", "velocity"})
    needs: ClassVar[frozenset[str]] = frozenset({"coriolis_transpose", "gravity"})

    def __init__(self, config: MomentumConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.gain = np.broadcast_to(config.K, self.shape).copy()  # K_I, diagonal
        #: The residual r, a torque [N m].
        self.residual = np.zeros(self.shape)
        self.signals["residual"] = self.residual
        self._integral = np.zeros(self.shape)  # z = p(0) + integral (tau + C^T qd - G + r)
        self._momentum = np.zeros(self.shape)  # p = M qd
        self._rate = np.zeros(self.shape)
        self._model_terms = np.zeros(self.shape)  # T/2 (C^T qd - G) at the period's sample
        self._half_dt = scalar(float(dt) / 2)
        self._started = False

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        """r = 0; z is set to the first period's p (the mass matrix is not known before it)."""
        super().reset(q_hat, qd_hat)
        self.residual[:] = 0.0
        self._integral[:] = 0.0
        self._started = False

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        if qd_meas is None:  # the scenario loader refuses this; a direct caller gets a clear message
            raise ValueError("momentum needs measured velocities (momentum_levant differentiates the encoders)")
        self.q_hat[:] = q_meas
        self.qd_hat[:] = qd_meas

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        r""":math:`r_k = K_I (p_k - z_k)`, :math:`z_k` completed with the second half of the previous period's
        trapezoid."""
        if not self._started and (getattr(model, "coriolis_transpose", None) is None
                                  or getattr(model, "gravity", None) is None):
            raise ValueError(f"{self.name} needs the nominal model's C^T qd and G: a StepModel with "
                             "coriolis_transpose and gravity (the engine gives them for Observer.needs)")
        momentum = model.apply_M(self.qd_hat, out=self._momentum)
        half = np.subtract(model.coriolis_transpose, model.gravity, out=self._model_terms)
        friction = getattr(model, "friction", None)
        if friction is not None:  # the nominal joint friction: dp/dt = tau + C^T qd - G - F
            half -= friction
        half *= self._half_dt
        if self._started:  # + T/2 (C^T qd - G) at this end of the period
            self._integral += half
        else:  # z(0) = p(0): r(0) = 0
            self._integral[:] = momentum
            self._started = True
        residual = np.subtract(momentum, self._integral, out=self.residual)
        residual *= self.gain
        self.luaf_hat[:] = model.solve_M(residual)
        self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        r""":math:`z \leftarrow z + T (\tau + r) + \tfrac{T}{2} (C^T \dot q - G - F)` of this end of the period
        (formed in :meth:`update`)."""
        rate = np.add(tau, self.residual, out=self._rate)
        rate *= self.dt
        self._integral += rate
        self._integral += self._model_terms


class LevantMomentumObserver(LevantVelocity, MomentumObserver):
    """The momentum observer on the velocity estimate of Levant's differentiator: position-only."""

    name: ClassVar[str] = "momentum_levant"
    Config: ClassVar[type[LevantMomentumConfig]] = LevantMomentumConfig
