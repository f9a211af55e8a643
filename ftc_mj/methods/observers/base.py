"""The observer plugin protocol.

An observer sees what a real one would: time, the measured joint positions (and velocities, where the robot
has tachometers) and the command it applied, plus the nominal model. It never receives MjData. Each control
period the loop (:mod:`ftc_mj.engine.loop`) calls

0. :meth:`Observer.measure` with the raw readings, before the nominal model is evaluated;
1. :meth:`Observer.update` with the new measurement: the observer forms its output injection at this instant;
2. the controller, which reads ``qd_hat``, ``luaf_hat`` and ``injection``;
3. :meth:`Observer.advance` with the torque just commanded: the observer integrates over one period.

The split lets a controller cancel exactly the injection the observer applies in the same period, which is
what the equivalent controls of Chapters 3-5 do (e.g. the terms of eq. (5.26) that come from (5.6)).

State and inputs are ``(members, n)``: the contract of :class:`ftc_mj.methods.plugin.Method` (shapes, gains, reset).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from ftc_mj.methods.gains import GainConfig
from ftc_mj.methods.plugin import Method
from ftc_mj.methods.primitives import signed_power
from ftc_mj.robot.nominal import StepModel

__all__ = ["Observer", "signed_power"]  # signed_power re-exported: plugins import it from here


class Observer(Method):
    r"""Estimates joint velocity and the lumped uncertainty and fault (LUaF) from positions.

    Attributes after :meth:`update`:
        q_hat, qd_hat: state estimate :math:`\hat x_1`, :math:`\hat x_2`.
        luaf_hat: estimate of the lumped uncertainty and fault, in acceleration units.
        injection: the whole output injection into the observer's velocity equation (the estimate plus the
            correction terms); Chapter 3-5 controllers compensate this, Appendix-D-type ones ``luaf_hat``.

    Class attribute ``needs``: the nominal quantities beyond M and :math:`\Psi` the observer reads from its
    :class:`StepModel` (names of :data:`ftc_mj.robot.nominal.NEEDS`, e.g. ``coriolis_transpose``); the engine
    evaluates them only for the observers that declare them. Empty by default.
    """

    needs: ClassVar[frozenset[str]] = frozenset()

    def __init__(self, config: GainConfig, n_joints: int, dt: float, members: int | None = None):
        super().__init__(config, n_joints, dt, members)
        self.q_hat = np.zeros(self.shape)
        self.qd_hat = np.zeros(self.shape)
        self.luaf_hat = np.zeros(self.shape)
        self.injection = np.zeros(self.shape)

    def reset(self, q_hat: np.ndarray, qd_hat: np.ndarray) -> None:
        """Start from the given estimate, with a zero LUaF estimate."""
        self.q_hat[:] = q_hat
        self.qd_hat[:] = qd_hat
        self.luaf_hat[:] = 0.0
        self.injection[:] = 0.0

    def measure(self, q_meas: np.ndarray, qd_meas: np.ndarray | None) -> None:
        r"""Take this period's raw readings (``qd_meas`` is None without tachometers).

        Called before the nominal model is evaluated at ``(q_hat, qd_hat)``. Observers built on measured
        states (the DO of Chapter 2) set ``q_hat`` and ``qd_hat`` to the readings here, so that :math:`\Psi` is
        the measured-state :math:`H(x)` of (2.6) and (2.25). The default does nothing.
        """

    @abstractmethod
    def update(self, t: float, q_meas: np.ndarray, model: StepModel) -> None:
        """Take the measurement of time ``t`` and form this period's injection."""

    @abstractmethod
    def advance(self, tau: np.ndarray, model: StepModel) -> None:
        """Integrate the observer over one control period with the applied torque ``tau``."""
