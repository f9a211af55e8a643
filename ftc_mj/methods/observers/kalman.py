r"""A Kalman filter with a disturbance state, per joint on its position, velocity and disturbance
:math:`(q, \dot q, d)`, position measurements only: the common "disturbance Kalman filter" (e.g. Hu and Xiong's
and Wahrburg et al.'s collision estimators; Kalman 1960, Jazwinski 1970 for the filter itself).

Model of each joint, with d the LUaF (acceleration units, :math:`\Delta` of the plant (5.2)) as a random walk:

.. math::

    \frac{d}{dt} q = \dot q + w_q, \quad \frac{d}{dt} \dot q = u + d + w_{\dot q}, \quad \frac{d}{dt} d = w_d,
    \quad y = q + v, \qquad u = \Psi(\hat q, \hat{\dot q}) + M(x_1)^{-1} \tau

:math:`w_q`, :math:`w_{\dot q}`, :math:`w_d` white with spectral densities :math:`S_q`, :math:`S_{\dot q}`,
:math:`S_d` (``process_q``, ``process_qd``, ``process_d``, per joint), v white with variance R
(``measurement``, per sample [rad^2]; an encoder of step s adds :math:`s^2 / 12`).

**Tuning.** The filter is optimal for its model, so its covariances are its bandwidth: a ``process_d`` much
larger than the LUaF's real motion makes a fast filter that passes the encoder's noise into ``qd_hat`` and
``luaf_hat`` (the noise's share of the error variance is the solution of a Lyapunov equation in the
steady-state gain). A rule that needs no trial: ``measurement`` from the encoder (:math:`s^2 / 12` plus its
noise's variance); ``process_d`` :math:`S_d = D^2 T` from a bound D on :math:`|\dot d|` (the bound the TOSMOs are
designed for, Remark 5.3), so that the random walk's step over a period, :math:`\sqrt{S_d T}`,
is the largest change of d in a period, D T (the Wiener-process models of Bar-Shalom, Li and Kirubarajan,
"Estimation with Applications to Tracking and Navigation", Wiley 2001, section 6.2-6.3: the noise's step over a
period of the order of the state's largest change, 0.5 to 1 times it); ``process_qd`` = 0, since d already
lumps every unknown acceleration.

**What is linearised.** The coupling of the joints through :math:`\Psi(q, \dot q)` and :math:`M^{-1}` is not
modelled in the covariance: :math:`\Psi + M^{-1} \tau` enters as a known input, evaluated at the filter's
estimate (the Jacobian of :math:`\Psi` is neglected). Each joint is then a linear chain of integrators with a
model input, so the filter is a linear Kalman filter per joint (an EKF whose state Jacobian is the chain's),
and its gains do not depend on the robot's state.

**Discrete time.** The chain :math:`\dot x = A x + b u` is discretised exactly at the period T with the input
held (zero-order hold), and its noise by Van Loan's integral, in closed form:

.. math::

    F = \begin{bmatrix} 1 & T & T^2/2 \\ 0 & 1 & T \\ 0 & 0 & 1 \end{bmatrix}, \quad
    B = \begin{bmatrix} T^2/2 \\ T \\ 0 \end{bmatrix}, \quad
    Q = \int_0^T e^{A s} \operatorname{diag}(S_q, S_{\dot q}, S_d)\, e^{A^T s}\, ds

Each period:

* :meth:`measure` (the measurement update, before the nominal model is evaluated), with
  :math:`H = [1, 0, 0]` and R the variance ``measurement``: the innovation :math:`\nu = y - q^-`,
  :math:`S = P_{00} + R`, :math:`K = P_{:,0} / S`, :math:`x \leftarrow x + K \nu`,
  :math:`P \leftarrow P - K P_{0,:}`; so :math:`\Psi` is then taken at the corrected estimate;
* :meth:`update`: the injection is the LUaF estimate :math:`\hat d` (the filter has no output injection into a
  velocity equation a controller could cancel beyond its disturbance estimate);
* :meth:`advance` (the time update): :math:`x \leftarrow F x + B u`, :math:`P \leftarrow F P F^T + Q`.

**Storage.** P is symmetric: its six entries (:math:`P_{00}, P_{01}, P_{02}, P_{11}, P_{12}, P_{22}`) are one
contiguous ``(6, members, n)`` array per stage (the prediction and the corrected estimate), and
:math:`(q, \dot q, d)` one ``(3, members, n)`` array whose rows are ``q_hat``, ``qd_hat``, ``luaf_hat``. Each
step of the recursion is a NumPy call on whole rows or blocks of rows of the same shape (at these sizes
NumPy's cost per call, and more for a broadcast operand, outweighs the arithmetic). Every operation is
element-wise (products and sums in a fixed order, no reduction), so a member's bits do not depend on the
batch. The updates per entry:

* measurement: row 0 becomes :math:`P_{0j} R / S = K_j R` (the standard form :math:`P_{0j} - K_0 P_{0j}`
  without its cancellation when :math:`R \ll P_{00}`), and :math:`P_{ij} \leftarrow P_{ij} - K_i P_{0j}` for
  :math:`i, j \ge 1` (:math:`P_{11}`, :math:`P_{12}` with :math:`K_1`, :math:`P_{22}` with :math:`K_2`);
* time: :math:`F P F^T` of a symmetric P, per entry (:math:`h = T^2/2`), as below, summed by diagonal of this
  table (the coefficients of entry i + o in entry i, o = 1..5: one product and one sum of blocks each) into
  P + Q:

.. math::

    \begin{aligned}
    P_{00} &\leftarrow P_{00} + 2T P_{01} + 2h P_{02} + T^2 P_{11} + 2Th P_{12} + h^2 P_{22} \\
    P_{01} &\leftarrow P_{01} + T P_{02} + T P_{11} + (T^2 + h) P_{12} + hT P_{22} \\
    P_{02} &\leftarrow P_{02} + T P_{12} + h P_{22} \\
    P_{11} &\leftarrow P_{11} + 2T P_{12} + T^2 P_{22} \\
    P_{12} &\leftarrow P_{12} + T P_{22}
    \end{aligned}

P stays exactly symmetric (each entry is stored once); :attr:`KalmanObserver.covariance` assembles the
``(members, n, 3, 3)`` matrices. The innovation :math:`\nu` is recorded as the signal ``innovation`` (for a
whiteness test: white when the model and the covariances are right).

**The steady state, exactly.** F, Q and R are constant, so the covariances and gains do not depend on the
data (Kalman 1960): :math:`P_{k+1}` is a fixed function of :math:`P_k`. In floating point the recursion
reaches, after a few hundred periods, a fixed point or a cycle of a few periods in the last bits. Once the
prediction's covariance of the whole batch repeats bit for bit a value it had p periods before
(p at most :attr:`KalmanObserver.window`), every later gain is the one of p periods earlier: the filter stores
the p gains and replays them, and stops the covariance recursion. The estimates are bit for bit those of the
full recursion (a member's own sequence, whatever the batch); only the cost changes (the state update alone).
A batch whose members' periods have no common multiple up to the window keeps the full recursion.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import Field

from ftc_mj.methods.gains import GainConfig, NonNegativeJoints, PositiveJoints
from ftc_mj.methods.observers.base import Observer
from ftc_mj.methods.primitives import scalar
from ftc_mj.robot.nominal import StepModel


class KalmanConfig(GainConfig):
    """Covariances of the disturbance Kalman filter, per joint."""

    #: Spectral density :math:`S_q` of the white noise on the position's rate [rad^2/s].
    process_q: NonNegativeJoints = Field(0.0, validate_default=True)
    #: Spectral density :math:`S_{\dot q}` of the white noise on the velocity's rate [rad^2/s^3].
    process_qd: NonNegativeJoints = Field(0.0, validate_default=True)
    #: Spectral density :math:`S_d` of the random walk of d [rad^2/s^5]: how fast the LUaF may move.
    process_d: PositiveJoints
    #: Variance R of one position measurement [rad^2].
    measurement: PositiveJoints
    #: Initial covariance of q, qd, d (diagonal).
    initial_q: PositiveJoints = Field(1e-6, validate_default=True)
    initial_qd: PositiveJoints = Field(1.0, validate_default=True)
    initial_d: PositiveJoints = Field(100.0, validate_default=True)


#: The stored entries of the symmetric 3x3 covariance, in the order of :attr:`KalmanObserver.entries`.
ENTRIES: tuple[tuple[int, int], ...] = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def pack(P: np.ndarray) -> np.ndarray:
    """The six entries of symmetric matrices ``(..., 3, 3)`` as ``(6, ...)`` (the upper triangle)."""
    return np.stack([P[..., i, j] for i, j in ENTRIES])


def unpack(entries: np.ndarray) -> np.ndarray:
    """The symmetric matrices ``(..., 3, 3)`` of six entries ``(6, ...)``."""
    P = np.empty(entries.shape[1:] + (3, 3))
    for entry, (i, j) in zip(entries, ENTRIES):
        P[..., i, j] = P[..., j, i] = entry
    return P


def process_covariance(T: float, process_q, process_qd, process_d, shape: tuple[int, ...]) -> np.ndarray:
    r"""Q of the chain of integrators over a period T for white noise of the given spectral densities on each
    state's derivative, ``shape + (3, 3)``:
    :math:`\int_0^T \Phi(s) \operatorname{diag}(S_q, S_{\dot q}, S_d) \Phi(s)^T ds` with
    :math:`\Phi(s) = e^{A s}`, in closed form (Van Loan 1978)."""
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


def time_update_diagonals(T: float) -> tuple[np.ndarray, ...]:
    r"""The coefficients of :math:`P \to F P F^T` on the six entries (:data:`ENTRIES`) by offset: diagonal o holds the
    coefficients of entry i + o in entry i, i = 0 .. 5 - o (the module docstring's table; the identity is
    offset 0). Returns the diagonals of offsets 1 to 5, of lengths 5 to 1."""
    h = T * T / 2
    return tuple(np.array(diagonal) for diagonal in (
        [2 * T, T, 0.0, 2 * T, T],                 # P01 -> P00, P02 -> P01, P11 -> P02, P12 -> P11, P22 -> P12
        [2 * h, T, T, T * T],                      # P02 -> P00, P11 -> P01, P12 -> P02, P22 -> P11
        [T * T, T * T + h, h],                     # P11 -> P00, P12 -> P01, P22 -> P02
        [2 * T * h, h * T],                        # P12 -> P00, P22 -> P01
        [h * h]))                                  # P22 -> P00


class KalmanObserver(Observer):
    r"""Per-joint Kalman filter on :math:`(q, \dot q, d)` with the nominal model as known input,
    :math:`u = \Psi + M(x_1)^{-1} \tau` of (5.2) (see the module docstring)."""

    name: ClassVar[str] = "kalman"
    signal_names: ClassVar[frozenset[str] | None] = frozenset({"innovation"})
    Config: ClassVar[type[KalmanConfig]] = KalmanConfig
    #: The longest period of the covariance's steady state looked for (0: always the full recursion). 24 is a
    #: common multiple of the periods 1, 2, 3, 4, 6, 8 the recursion ends in.
    window: ClassVar[int] = 24

    def __init__(self, config: KalmanConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        T = float(dt)
        shape = self.shape
        #: (``q_hat``, ``qd_hat``, ``luaf_hat``) as one ``(3,) + shape`` array; the three estimates are its rows.
        self.state = np.zeros((3,) + shape)
        self.q_hat, self.qd_hat, self.luaf_hat = self.state
        #: The entries P00, P01, P02, P11, P12, P22 (:data:`ENTRIES`), ``(6,) + shape``, of the covariance of
        #: the prediction (what :meth:`advance` leaves and :meth:`measure` reads) ...
        self.entries = np.zeros((6,) + shape)
        #: ... and of the corrected estimate (what :meth:`measure` leaves and :meth:`advance` reads).
        self.posterior = np.zeros((6,) + shape)
        self.process = pack(process_covariance(T, config.process_q, config.process_qd, config.process_d, shape))
        self.initial = np.zeros((6,) + shape)
        for k, name in ((0, "initial_q"), (3, "initial_qd"), (5, "initial_d")):
            self.initial[k] = getattr(config, name)
        self.measurement_variance = np.broadcast_to(config.measurement, shape).copy()
        self._measurement_rows = np.ascontiguousarray(np.broadcast_to(self.measurement_variance, (3,) + shape))
        #: The gain K of the full recursion's last measurement update, ``(3,) + shape`` (in the steady state
        #: the stored cycle's gains are applied instead).
        self.gain = np.zeros((3,) + shape)
        self.innovation = np.zeros(shape)
        self.signals["innovation"] = self.innovation
        #: The period of the covariance's steady state once found (the gains are then replayed), else None.
        self.period: int | None = None
        self._half_T2 = scalar(T * T / 2)
        self._variance = np.zeros(shape)  # S
        self._input = np.zeros(shape)
        self._term = np.zeros(shape)
        self._block = np.zeros((5,) + shape)  # the products of one diagonal of the time update
        # The diagonals expanded to their blocks' shape: a product of two arrays of one shape.
        diagonals = [np.ascontiguousarray(np.broadcast_to(d.reshape(d.shape + (1,) * len(shape)), d.shape + shape))
                     for d in time_update_diagonals(T)]
        # Views made once: the per-period work is then only the ufunc calls.
        self._prior_entries, self._posterior_entries = tuple(self.entries), tuple(self.posterior)
        self._gain_rows = self.posterior[:3]
        self._corrections = tuple(zip(self.state, self.gain))
        self._time_terms = tuple((diagonal, self.posterior[o:], self._block[:6 - o], self.entries[:6 - o])
                                 for o, diagonal in enumerate(diagonals, start=1))
        # The last window's gains and predictions, and where the current period falls in it.
        self._gains = np.zeros((self.window, 3) + shape)
        self._priors = np.zeros((self.window, 6) + shape)
        self._bits = self.entries.view(np.int64)  # compared bit for bit (-0.0 is not 0.0 to the recursion)
        self._first_bits = self._priors[0].view(np.int64) if self.window else None
        self._offset = 0
        self._phase = 0
        self._cycle: tuple[tuple[tuple[np.ndarray, np.ndarray], ...], ...] = ()
        self._cycle_priors = self._priors[:0]

    @property
    def covariance(self) -> np.ndarray:
        """The covariance of the prediction as ``shape + (3, 3)`` matrices (a copy)."""
        return unpack(self.entries if self.period is None else self._cycle_priors[self._phase])

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        super().reset(q_hat, qd_hat)
        self.entries[:] = self.initial
        self.innovation[:] = 0.0
        self.period, self._offset, self._phase, self._cycle = None, 0, 0, ()

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        """The measurement update with this period's encoder reading (H = [1, 0, 0])."""
        nu = np.subtract(q_meas, self.q_hat, out=self.innovation)
        term = self._term
        if self.period is not None:  # the steady state: this period's gain, stored
            corrections = self._cycle[self._phase]
            self._phase = (self._phase + 1) % self.period
            for state, k in corrections:
                state += np.multiply(k, nu, out=term)
            return
        P00, P01, P02, P11, P12, P22 = self._prior_entries
        posterior, (K0, K1, K2) = self._posterior_entries, self.gain
        S = np.add(P00, self.measurement_variance, out=self._variance)
        np.divide(P00, S, out=K0)  # K = P[:, 0] / S
        np.divide(P01, S, out=K1)
        np.divide(P02, S, out=K2)
        for state, k in self._corrections:
            state += np.multiply(k, nu, out=term)
        # Row 0 becomes K R; P11 -= K1 P01, P12 -= K1 P02, P22 -= K2 P02.
        np.multiply(self.gain, self._measurement_rows, out=self._gain_rows)
        np.subtract(P11, np.multiply(K1, P01, out=term), out=posterior[3])
        np.subtract(P12, np.multiply(K1, P02, out=term), out=posterior[4])
        np.subtract(P22, np.multiply(K2, P02, out=term), out=posterior[5])
        if self.window:
            self._gains[self._offset] = self.gain
            self._priors[self._offset] = self.entries

    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        self.injection[:] = self.luaf_hat

    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        r"""The time update :math:`x \leftarrow F x + B u`, :math:`P \leftarrow F P F^T + Q`."""
        u = np.add(model.psi_hat, model.command_acceleration(tau), out=self._input)
        u += self.luaf_hat  # qdd_hat = u + d_hat
        # q += T qd + T^2/2 (u + d), then qd += T (u + d); d stays.
        q_hat, qd_hat, term = self.q_hat, self.qd_hat, self._term
        q_hat += np.multiply(self.dt, qd_hat, out=term)
        q_hat += np.multiply(self._half_T2, u, out=term)
        qd_hat += np.multiply(self.dt, u, out=term)
        if self.period is not None:
            return
        np.add(self.posterior, self.process, out=self.entries)
        for diagonal, sources, terms, targets in self._time_terms:
            targets += np.multiply(diagonal, sources, out=terms)
        if self.window:
            self._offset += 1
            if np.array_equal(self._bits, self._first_bits):
                self._repeat(self._offset)
            elif self._offset == self.window:
                self._offset = 0

    def _repeat(self, period: int) -> None:
        """The prediction's covariance is the one of ``period`` periods ago: replay that period's gains."""
        self.period, self._phase = period, 0
        gains = self._gains[:period].copy()
        self._cycle_priors = self._priors[:period].copy()
        self._cycle = tuple(tuple(zip(self.state, gain)) for gain in gains)
