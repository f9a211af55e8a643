"""What one control period hands the plugins of the nominal model (:class:`StepModel`), and the quantities
beyond M and Psi an observer may ask for (:data:`NEEDS`)."""

from __future__ import annotations

import numpy as np

from ftc_mj.robot.nominal.matrices import MatvecSite
from ftc_mj.robot.nominal.solve import SparseSolver


#: The nominal quantities beyond M and Psi that an observer may declare in ``needs``
#: (:attr:`~ftc_mj.methods.observers.base.Observer.needs`): the engine then has the nominal batch evaluate them
#: at that observer's points (``momentum_points`` of :func:`nominal_batch`) and hands them to it as the
#: :class:`StepModel` attributes of the same names. C(q, qd)^T qd and G(q), the generalized momentum observer's
#: beta = G - C^T qd (De Luca and Mattone, ICRA 2005), are evaluated together.
NEEDS = frozenset({"coriolis_transpose", "gravity"})

class StepModel:
    r"""Nominal quantities of one control period for a block of members, computed once and shared by the
    observer and the controller (views of the engine's batched evaluation, :class:`NominalBatch`): the terms of
    the plant (5.2), :math:`\ddot q = \Psi(q, \dot q) + M(q)^{-1} \tau + \Delta` with
    :math:`\Psi = -M^{-1} (C \dot q + G + F)`.

    Attributes:
        M: :math:`M(x_1)` at the measured position, ``(members, n, n)``.
        psi_hat: :math:`\Psi(\hat x_1, \hat x_2)` at the observer's state estimate, ``(members, n)``: what the
            observers integrate.
        psi_control: :math:`\Psi` at the state the controller uses. With a tachometer reading ``qd_measured`` (a
            robot with tachometers whose chapter feeds the controller the measured velocity, Chapter 2:
            :math:`H(x)` of (2.25), (2.32)) it is :math:`\Psi(x_1, x_2)` at the readings; otherwise it is
            ``psi_hat`` itself (the same array).
        qd_measured: the tachometer readings the controller uses, or None when it uses the estimate
            :math:`\hat x_2`.
        coriolis_transpose: :math:`C(q, \dot q)^T \dot q` at the observer's state estimate (the point of
            ``psi_hat``), ``(members, n)``, with C the Coriolis matrix for which :math:`\dot M - 2C` is
            skew-symmetric; only for an observer that declares it in ``needs`` (:data:`NEEDS`), else None.
        gravity: :math:`G(q)` at the observer's estimate, ``(members, n)``; only where declared in ``needs``,
            else None.
        friction: the nominal joint friction :math:`F(\dot q)` at the observer's point
            (:mod:`ftc_mj.robot.friction`), ``(members, n)``, already inside ``psi_hat``; None where the nominal
            model has none.
    """

    def __init__(self, M: np.ndarray, factor: np.ndarray, diagonal_inverse: np.ndarray, psi_hat: np.ndarray,
                 solver: SparseSolver, psi_control: np.ndarray | None = None,
                 qd_measured: np.ndarray | None = None, command: np.ndarray | None = None,
                 coriolis_transpose: np.ndarray | None = None, gravity: np.ndarray | None = None,
                 friction: np.ndarray | None = None):
        r"""``command``: where the engine puts :math:`M(x_1)^{-1} \tau` of the period's command once the
        controllers have run, solved for every row of its batch at once (see :meth:`command_acceleration`); None:
        solved on demand. ``coriolis_transpose``, ``gravity``: the nominal batch's rows of these quantities at the
        observer's points, or None."""
        self.M, self.psi_hat = M, psi_hat
        self.psi_control = psi_hat if psi_control is None else psi_control
        self.qd_measured = qd_measured
        self.coriolis_transpose, self.gravity = coriolis_transpose, gravity
        self.friction = friction
        self._factor, self._diagonal_inverse, self._solver = factor, diagonal_inverse, solver
        self._solution = np.zeros(psi_hat.shape)
        self._command = command
        self._apply = MatvecSite()

    def control_velocity(self, observer_qd_hat: np.ndarray) -> np.ndarray:
        r"""The velocity :math:`x_2` the controller uses: the tachometer reading or the observer's
        :math:`\hat x_2`."""
        return observer_qd_hat if self.qd_measured is None else self.qd_measured

    def solve_M(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1)^{-1} v` per member (v the ``vector``), as ``mj_solveM`` computes it. Returns an internal
        buffer (no allocation per step): valid until the next call."""
        return self._solver.solve(self._factor, self._diagonal_inverse, vector, self._solution)

    def command_acceleration(self, tau: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1)^{-1} \tau` for the command ``tau`` of this period (what an observer integrates in
        :meth:`~ftc_mj.methods.observers.base.Observer.advance`, e.g. eq. (5.6)). In the engine it was solved
        for every row at once after the controllers ran (the same bits as :meth:`solve_M`); elsewhere it is
        solved here. Valid until the next call or period."""
        return self.solve_M(tau) if self._command is None else self._command

    def apply_M(self, vector: np.ndarray, out: np.ndarray) -> np.ndarray:
        r""":math:`M(x_1) v` per member (v the ``vector``), into ``out``."""
        site = self._apply
        if vector is site.vectors and out is site.out and self.M is site.matrices:
            site.call()
            return out
        return site.new(self.M, vector, out)
