"""A Kalman filter with a disturbance state, per joint on (q, qd, d), position measurements only: the common
"disturbance Kalman filter" (e.g. Hu and Xiong's and Wahrburg et al.'s collision estimators; Kalman 1960,
Jazwinski 1970 for the filter itself).

Model of each joint, with d the LUaF (acceleration units) as a random walk:

    dq/dt = qd + w_q,   dqd/dt = u + d + w_qd,   dd/dt = w_d,   y = q + v
    u = Psi(q_hat, qd_hat) + M(x1)^-1 tau

w_q, w_qd, w_d white with spectral densities ``process_q``, ``process_qd``, ``process_d`` (per joint), v white
with variance ``measurement`` (per sample, rad^2; an encoder of step s adds s^2 / 12).

**What is linearised.** The coupling of the joints through Psi(q, qd) and M^-1 is not modelled in the
covariance: Psi + M^-1 tau enters as a known input, evaluated at the filter's estimate (the Jacobian of Psi is
neglected). Each joint is then a linear chain of integrators with a model input, so the filter is a linear
Kalman filter per joint (an EKF whose state Jacobian is the chain's), and its gains do not depend on the
robot's state.

**Discrete time.** The chain is discretised exactly at the period T with the input held (zero-order hold):

    F = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]],   B = [T^2/2, T, 0]
    Q = integral_0^T e^(A s) diag(process_q, process_qd, process_d) e^(A^T s) ds     (Van Loan, closed form)

Each period:

* :meth:`measure` (the measurement update, before the nominal model is evaluated): innovation
  nu = y - q_prior, S = P00 + R, K = P[:, 0] / S, x += K nu, P -= P[:, 0] P[0, :] / S; so Psi is then taken
  at the corrected estimate;
* :meth:`update`: the injection is the LUaF estimate d_hat (the filter has no output injection into a velocity
  equation a controller could cancel beyond its disturbance estimate);
* :meth:`advance` (the time update): x = F x + B u, P = F P F^T + Q.

The covariance is a ``(members, n, 3, 3)`` array; F P F^T is applied as the row operations of F and then the
column operations of F^T (F is the same for every member and joint), element-wise on the whole batch, and the
upper triangle is mirrored so that P stays exactly symmetric. The innovation nu is recorded as the signal
``innovation`` (for a whiteness test: white when the model and the covariances are right).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field

from ftc_mj.methods.gains import GainConfig, NonNegativeJoints, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.robot.nominal import StepModel


class KalmanConfig(GainConfig):
    """Covariances of the disturbance Kalman filter, per joint."""

    #: Spectral density of the white noise on dq/dt [rad^2/s].
    process_q: NonNegativeJoints = Field(0.0, validate_default=True)
    #: Spectral density of the white noise on dqd/dt [rad^2/s^3].
    process_qd: NonNegativeJoints = Field(0.0, validate_default=True)
    #: Spectral density of the random walk of d [rad^2/s^5]: how fast the LUaF may move.
    process_d: PositiveJoints
    #: Variance of one position measurement [rad^2].
    measurement: PositiveJoints
    #: Initial covariance of q, qd, d (diagonal).
    initial_q: PositiveJoints = Field(1e-6, validate_default=True)
    initial_qd: PositiveJoints = Field(1.0, validate_default=True)
    initial_d: PositiveJoints = Field(100.0, validate_default=True)


def process_covariance(T: float, process_q, process_qd, process_d, shape: tuple[int, ...]) -> np.ndarray:
    """Q of the chain of integrators over a period T for white noise of the given spectral densities on each
    state's derivative, ``shape + (3, 3)``: the integral of Phi(s) diag(q, qd, d) Phi(s)^T over [0, T] with
    Phi(s) = e^(A s), in closed form."""
    q = np.broadcast_to(process_q, shape)
    qd = np.broadcast_to(process_qd, shape)
    d = np.broadcast_to(process_d, shape)
    Q = np.zeros(shape + (3, 3))
    Q[..., 0, 0] = q * T + qd * T**3 / 3 + d * T**5 / 20
    Q[..., 0, 1] = Q[..., 1, 0] = qd * T**2 / 2 + d * T**4 / 8
    Q[..., 0, 2] = Q[..., 2, 0] = d * T**3 / 6
    Q[..., 1, 1] = qd * T + d * T**3 / 3
    Q[..., 1, 2] = Q[..., 2, 1] = d * T**2 / 2
    Q[..., 2, 2] = d * T
    return Q


class KalmanObserver(Observer):
    """Per-joint Kalman filter on (q, qd, d) with the nominal model as known input (see the module docstring)."""

    name: ClassVar[str] = "kalman"
    Config: ClassVar[type[KalmanConfig]] = KalmanConfig

    def __init__(self, config: KalmanConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        T = float(dt)
        self._T, self._half_T2 = self.dt, T * T / 2  # F's entries T and T^2/2
        shape = self.shape
        self.process = process_covariance(T, config.process_q, config.process_qd, config.process_d, shape)
        self.initial = np.zeros(shape + (3, 3))
        for i, name in enumerate(("initial_q", "initial_qd", "initial_d")):
            self.initial[..., i, i] = getattr(config, name)
        self.measurement_variance = np.broadcast_to(config.measurement, shape).copy()
        #: The covariance P, ``shape + (3, 3)``.
        self.covariance = self.initial.copy()
        self.innovation = np.zeros(shape)
        self.signals["innovation"] = self.innovation
        self._variance = np.zeros(shape)  # S
        self._gain = np.zeros(shape + (3,))  # K
        self._row = np.zeros(shape + (3,))  # a row or column operation of F
        self._outer = np.zeros(shape + (3, 3))
        self._term = np.zeros(shape)
        self._input = np.zeros(shape)

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        super().reset(q_hat, qd_hat)
        self.covariance[:] = self.initial
        self.innovation[:] = 0.0

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        """The measurement update with this period's encoder reading (H = [1, 0, 0])."""
        P = self.covariance
        np.subtract(q_meas, self.q_hat, out=self.innovation)
        variance = np.add(P[..., 0, 0], self.measurement_variance, out=self._variance)
        gain = np.divide(P[..., :, 0], variance[..., None], out=self._gain)
        for state, k in ((self.q_hat, gain[..., 0]), (self.qd_hat, gain[..., 1]), (self.luaf_hat, gain[..., 2])):
            np.multiply(k, self.innovation, out=self._term)
            state += self._term
        # P -= P[:, 0] P[0, :] / S: (P_i0 P_0j) / S is the same product for (i, j) and (j, i), so P stays symmetric.
        outer = np.multiply(P[..., :, 0, None], P[..., None, 0, :], out=self._outer)
        outer /= variance[..., None, None]
        P -= outer

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        """The time update x = F x + B u, P = F P F^T + Q."""
        T, h, term = self._T, self._half_T2, self._term
        u = np.add(model.psi_hat, model.command_acceleration(tau), out=self._input)
        u += self.luaf_hat  # qdd_hat = u + d_hat
        # q += T qd + T^2/2 (u + d), then qd += T (u + d); d stays.
        np.multiply(T, self.qd_hat, out=term)
        self.q_hat += term
        np.multiply(h, u, out=term)
        self.q_hat += term
        np.multiply(T, u, out=term)
        self.qd_hat += term
        P, row = self.covariance, self._row
        # F P: row 0 += T row 1 + T^2/2 row 2, then row 1 += T row 2 (row 2 unchanged).
        np.multiply(T, P[..., 1, :], out=row)
        P[..., 0, :] += row
        np.multiply(h, P[..., 2, :], out=row)
        P[..., 0, :] += row
        np.multiply(T, P[..., 2, :], out=row)
        P[..., 1, :] += row
        # (F P) F^T: the same on the columns.
        np.multiply(T, P[..., :, 1], out=row)
        P[..., :, 0] += row
        np.multiply(h, P[..., :, 2], out=row)
        P[..., :, 0] += row
        np.multiply(T, P[..., :, 2], out=row)
        P[..., :, 1] += row
        P += self.process
        P[..., 1, 0] = P[..., 0, 1]
        P[..., 2, 0] = P[..., 0, 2]
        P[..., 2, 1] = P[..., 1, 2]
